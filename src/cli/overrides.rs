//! Command-line overrides of a scene's settings, checked once.
//!
//! Input: the raw flags (`--width`, `--height`, `--method`, `--samples`,
//! `--step`). Output: [`Checked`] overrides, validated against the same
//! range table the scene file uses ([`crate::compile::limits`]), which
//! every subcommand applies the same way. Applying sizes and settings
//! cannot fail; the one check that depends on the scene (an integrating
//! method needs a space whose paths can be integrated) is made in
//! [`Checked::apply`], for render, probe, rays, explain and each save of
//! watch alike.

use clap::Args;

use super::CliError;
use crate::compile::limits::{Limit, HEIGHT, SAMPLES, STEP, WIDTH};
use crate::scene::{Method, Scene};

/// What the command line may change in a scene, as typed.
#[derive(Args, Clone, Debug, Default)]
pub struct Overrides {
    /// Image width in pixels (the height follows the scene's aspect
    /// ratio unless also given).
    #[arg(long, allow_negative_numbers = true)]
    pub width: Option<i64>,
    /// Image height in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub height: Option<i64>,
    /// Intersection method, overriding the scene: auto, exact, march,
    /// adaptive, interval or ode.
    #[arg(long)]
    pub method: Option<String>,
    /// Samples per pixel, overriding the scene.
    #[arg(long, allow_negative_numbers = true)]
    pub samples: Option<i64>,
    /// The marching step of the march and adaptive methods, overriding
    /// the scene.
    #[arg(long, allow_negative_numbers = true)]
    pub step: Option<f64>,
}

/// Overrides whose every value is within its range.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Checked {
    width: Option<u32>,
    height: Option<u32>,
    method: Option<Method>,
    samples: Option<u32>,
    step: Option<f64>,
}

/// `value` checked against `limit`, as the flag `--NAME`.
fn within(limit: &Limit, value: f64) -> Result<f64, CliError> {
    limit.check(value).map_err(|message| CliError::Argument {
        message: format!("--{message}"),
        help: limit.hint.to_string(),
    })
}

impl Overrides {
    /// Check every flag against the scene file's ranges.
    pub fn check(&self) -> Result<Checked, CliError> {
        // Taken as any whole number (so that `--width -5` is told its
        // range, not how clap passes a value starting with `-`).
        let whole = |limit: &Limit, v: Option<i64>| {
            v.map(|v| within(limit, v as f64).map(|v| v as u32))
                .transpose()
        };
        let method = match &self.method {
            None => None,
            Some(m) => Some(Method::from_name(m).ok_or_else(|| CliError::Argument {
                message: format!("unknown method `{m}`"),
                help: format!("choose one of: {}", Method::NAMES.join(", ")),
            })?),
        };
        Ok(Checked {
            width: whole(&WIDTH, self.width)?,
            height: whole(&HEIGHT, self.height)?,
            method,
            samples: whole(&SAMPLES, self.samples)?,
            step: self.step.map(|s| within(&STEP, s)).transpose()?,
        })
    }
}

impl Checked {
    /// Apply the overrides to `scene`, then check that the scene can
    /// render with them: `method ode` needs a space whose paths can be
    /// integrated.
    pub fn apply(&self, scene: &mut Scene) -> Result<(), CliError> {
        self.apply_size_and_settings(scene);
        self.check_step(scene)?;
        if let (Method::Ode, Some(reason)) =
            (scene.settings.method, scene.space.why_not_integrate())
        {
            return Err(CliError::Argument {
                message: format!("--method ode cannot be used here: {reason}"),
                help: scene.space.instead_of_integrating().into(),
            });
        }
        Ok(())
    }

    /// A `--step` must be larger than the scene's epsilon, as in the
    /// scene file (E0301 there).
    pub fn check_step(&self, scene: &Scene) -> Result<(), CliError> {
        match self.step {
            Some(step) if step <= scene.settings.epsilon => Err(CliError::Argument {
                message: format!(
                    "--step {} is not larger than the scene's epsilon ({})",
                    crate::compile::readable(step),
                    crate::compile::readable(scene.settings.epsilon)
                ),
                help: "step is the first stride of a march (0.01 is usual), epsilon how closely a hit is located; give a much larger step".into(),
            }),
            _ => Ok(()),
        }
    }

    /// Apply the sizes and settings alone (cannot fail: every value was
    /// checked). A width or height alone keeps the scene's aspect ratio.
    pub fn apply_size_and_settings(&self, scene: &mut Scene) {
        let before = (scene.camera.width, scene.settings.method);
        let max = WIDTH.max as u32;
        let cam = &mut scene.camera;
        let aspect = cam.height as f64 / cam.width as f64;
        match (self.width, self.height) {
            (Some(w), Some(h)) => (cam.width, cam.height) = (w, h),
            (Some(w), None) => {
                (cam.width, cam.height) = (w, ((w as f64 * aspect).round() as u32).clamp(1, max))
            }
            (None, Some(h)) => {
                (cam.width, cam.height) = (((h as f64 / aspect).round() as u32).clamp(1, max), h)
            }
            (None, None) => {}
        }
        if let Some(m) = self.method {
            scene.settings.method = m;
        }
        if let Some(s) = self.samples {
            scene.settings.samples = s;
        }
        if let Some(s) = self.step {
            scene.settings.step = s;
        }
        // The image's width and the method decide some warnings.
        if (scene.camera.width, scene.settings.method) != before {
            crate::compile::relint(scene);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value the scene file accepts is accepted as a flag, and one it
    /// rejects is rejected, with the scene's own message.
    #[test]
    fn flags_and_scene_files_share_their_ranges() {
        for (step, ok) in [(500.0, true), (0.01, true), (0.0, false), (-1.0, false)] {
            let source = format!("camera {{ position (-5, 0, 0) }}\nrender {{ step {step} }}");
            let in_file = crate::compile_source("t.nes", &source).is_ok();
            let as_flag = Overrides {
                step: Some(step),
                ..Overrides::default()
            }
            .check()
            .is_ok();
            assert_eq!((in_file, as_flag), (ok, ok), "step {step}");
        }
        for (samples, ok) in [(1, true), (1024, true), (1025, false), (0, false)] {
            let source =
                format!("camera {{ position (-5, 0, 0) }}\nrender {{ samples {samples} }}");
            let in_file = crate::compile_source("t.nes", &source).is_ok();
            let as_flag = Overrides {
                samples: Some(samples),
                ..Overrides::default()
            }
            .check()
            .is_ok();
            assert_eq!((in_file, as_flag), (ok, ok), "samples {samples}");
        }
    }

    /// `--method ode` is refused on a scene whose space has straight
    /// paths, and accepted where paths can be integrated.
    #[test]
    fn an_integrating_method_needs_a_space_that_integrates() {
        let ode = Overrides {
            method: Some("ode".into()),
            ..Overrides::default()
        }
        .check()
        .expect("ode is a method");
        let mut flat = crate::compile_source("t.nes", "camera { position (-5, 0, 0) }").unwrap();
        assert!(ode.apply(&mut flat).is_err());
        let mut curved = crate::compile_source(
            "t.nes",
            "camera { position (-5, 0, 0) }\nspace sphere { radius 10 }",
        )
        .unwrap();
        assert!(ode.apply(&mut curved).is_ok());
        assert_eq!(curved.settings.method, Method::Ode);
        // S3 and H3 refuse it because their geodesics are exact already.
        for space in ["s3", "h3"] {
            let source = format!("camera {{ position (-5, 0, 0) }}\nspace {space}");
            let mut scene = crate::compile_source("t.nes", &source).unwrap();
            let Err(CliError::Argument { message, help }) = ode.apply(&mut scene) else {
                panic!("{space}: ode accepted");
            };
            assert!(message.contains("exact geodesics"), "{space}: {message}");
            assert!(message.contains("closed form"), "{space}: {message}");
            assert!(!message.contains("straight"), "{space}: {message}");
            assert!(help.contains("auto"), "{space}: {help}");
        }
    }
}
