// POV-Ray twin of examples/gallery/chmutov-octic.nes, for the side-by-side
// timing in docs/performance.md (`scripts/povray-compare.sh`).
// nes is right-handed with z up; POV-Ray is left-handed with y up, so
// nes (x, y, z) is POV-Ray <x, z, y>. nes's fov 38 is across the image
// diagonal; POV-Ray's angle is across its width: at 800 x 500 that is
// 2 atan(tan(19 deg) * 800 / hypot(800, 500)) = 32.554 deg.
#version 3.7;
global_settings { assumed_gamma 1.0 max_trace_level 1 }
camera {
  perspective
  location <-4.6, 2.6, -3.2>
  look_at <0, 0, 0>
  right x * 800 / 500
  angle 32.554
}
background { rgb 0 }
light_source { <-6, 9, -7> rgb 1 }
light_source { <6, 4, -2> rgb 0.35 }
// T8(t) = 128 t^8 - 256 t^6 + 160 t^4 - 32 t^2 + 1, summed over x, y, z.
// The surface lies in |x|, |y|, |z| <= cosh(acosh(2) / 8) = 1.0136, the
// box a POV-Ray user would give it.
polynomial {
  8,
  xyz(8,0,0):128, xyz(6,0,0):-256, xyz(4,0,0):160, xyz(2,0,0):-32,
  xyz(0,8,0):128, xyz(0,6,0):-256, xyz(0,4,0):160, xyz(0,2,0):-32,
  xyz(0,0,8):128, xyz(0,0,6):-256, xyz(0,0,4):160, xyz(0,0,2):-32,
  xyz(0,0,0):3
  sturm
  bounded_by { box { -1.02, 1.02 } }
  pigment { rgb <0.949, 0.569, 0.278> }
  finish { ambient 0.15 diffuse 1 }
}
