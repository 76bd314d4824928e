//! Shorter formulas per cell: a union written with `min`, `max` or `smin`
//! of many pieces is searched, cell by cell, with only the pieces near
//! the cell. Each test compares with the same scene searched with the
//! whole function, which is guaranteed and computed another way.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

/// The scene in the space declared by `space` (a `space` directive, or
/// nothing for Euclidean space).
fn scene_in(space: &str, shape: &str) -> nes::Scene {
    let src = format!("{space}\ncamera {{ position (0, -9, 4) }}\nshape s = {shape}\nobject s");
    nes::compile_source("cells.nes", &src)
        .unwrap_or_else(|e| panic!("{space} {shape}: {}", e.render_plain()))
}

/// Rays from the camera's side towards the shape, hit by the scene with
/// its cell formulas and by the same scene without them: the same hits
/// to twice the search epsilon (1e-6; a cell
/// formula may be a quadric, met in closed form), and the same normals.
fn agrees_with_the_whole_function(shape: &str) {
    agrees_with_the_whole_function_in("", shape);
}

fn agrees_with_the_whole_function_in(space: &str, shape: &str) {
    let with = scene_in(space, shape);
    let pruned = with.objects[0].pruned.as_ref().expect("cell formulas");
    let whole_ops = with.objects[0].function.value_tape.operations() as f64;
    assert!(
        pruned.mean_operations() * 4.0 < whole_ops,
        "{shape}: {} of {whole_ops}",
        pruned.mean_operations()
    );
    let mut without = with.clone();
    without.objects[0].pruned = None;
    let (a, b) = (Tracer::new(&with), Tracer::new(&without));
    let (mut sa, mut sb) = (Scratch::default(), Scratch::default());
    let mut hits = 0;
    for k in 0..400 {
        let u = k as f64 * 0.618_034;
        let origin = DVec3::new(4.0 * (u * 1.7).sin(), -9.0, 4.0 * (u * 0.9).cos());
        let target = DVec3::new(3.0 * (u * 2.3).sin(), 0.0, 1.5 * (u * 3.1).cos());
        let d = (target - origin).normalize();
        let ha = a.nearest_hit(origin, d, 100.0, &mut sa);
        let hb = b.nearest_hit(origin, d, 100.0, &mut sb);
        match (ha, hb) {
            (Some(ha), Some(hb)) => {
                hits += 1;
                assert!(
                    (ha.t - hb.t).abs() < 2e-6,
                    "{shape}, ray {k}: {} vs {}",
                    ha.t,
                    hb.t
                );
                let (na, _) = a.normal_and_side(&ha, &mut sa);
                let (nb, _) = b.normal_and_side(&hb, &mut sb);
                assert!((na - nb).length() < 2e-5, "{shape}, ray {k}: {na} vs {nb}");
            }
            (None, None) => {}
            (ha, hb) => panic!(
                "{shape}, ray {k}: {:?} vs {:?}",
                ha.map(|h| h.t),
                hb.map(|h| h.t)
            ),
        }
    }
    // Aimed as in flat space, fewer rays meet the shape where paths bend.
    let least = if space.is_empty() { 100 } else { 40 };
    assert!(hits > least, "{space} {shape}: only {hits} rays hit");
}

#[test]
fn a_ring_of_balls_as_a_min_matches_the_whole_function() {
    agrees_with_the_whole_function(
        "min(k in 0..40, length((x - 2.5 * cos(k * tau / 40), y, z - 1.2 * sin(k * tau / 40))) - 0.3)",
    );
}

#[test]
fn capsules_with_the_radius_outside_the_min_match_the_whole_function() {
    // The radius is subtracted from the minimum, so only a level of the
    // pieces' distances matters: the pieces far above it are dropped.
    agrees_with_the_whole_function(
        "min(k in 0..48, let a = (2.5 * cos(k * tau / 48), 0, 1.2 * sin(2 * k * tau / 48)) in \
         let b = (2.5 * cos((k + 1) * tau / 48), 0, 1.2 * sin(2 * (k + 1) * tau / 48)) in \
         let q = (x, y, z) - a in let ba = b - a in \
         length(q - ba * clamp(dot(q, ba) / dot(ba, ba), 0, 1))) - 0.25",
    );
}

#[test]
fn a_smooth_union_of_many_balls_matches_the_whole_function() {
    let balls: Vec<String> = (0..16)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            format!(
                "sphere(0.35) translate ({:.4}, 0, {:.4})",
                2.6 * a.cos(),
                1.3 * a.sin()
            )
        })
        .collect();
    let mut shape = balls[0].clone();
    for b in &balls[1..] {
        shape = format!("smin({shape}, {b}, 0.2)");
    }
    agrees_with_the_whole_function(&shape);
}

/// Where paths curve, a piece of a path whose box lies in cells of one
/// formula is searched with it, and one across a cell face with the
/// formula of a block of cells holding it: the same hits as the whole
/// function, in S3 and H3.
#[test]
fn curved_paths_search_with_cell_and_block_formulas() {
    let ring = "min(k in 0..40, length((x - 2.5 * cos(k * tau / 40), y, z - 1.2 * sin(k * tau / 40))) - 0.3)";
    for space in ["space s3 { radius 10 }", "space h3 { radius 10 }"] {
        let curved = scene_in(space, ring);
        let pruned = curved.objects[0].pruned.as_ref().expect("cell formulas");
        assert!(!pruned.blocks.is_empty(), "{space}: block formulas");
        agrees_with_the_whole_function_in(space, ring);
    }
}
