//! Non-learned controllers (SPEC sections 4 and 8) acting on one agent's observation, and for
//! `scripted` on the inlet phase of its environment:
//! - `upstream`: a = (-1, 0), full thrust against the flow;
//! - `wall`: a = (-1/sqrt2, +-1/sqrt2), towards the nearer wall (the sign of obs`[1]` =
//!   (y - H/2) / (H/2));
//! - `wall-angle:DEG`: a = (-cos DEG, +-sin DEG) towards the nearer wall (`upstream` = 0,
//!   `wall` = 45 up to rounding);
//! - `heading:DEG`: a = (-cos DEG, sin DEG) for every member wherever it is: a fixed direction
//!   in the channel's frame, DEG from upstream towards the upper wall (y = H; negative DEG:
//!   towards y = 0). The one controller here that reads no observation at all;
//! - `zero`: a = 0; `random`: each component uniform in [-1, 1];
//! - `scripted` (privileged: it reads the waveform phase, which no learner observes): a
//!   wall-angle controller whose angle switches with the phase, `storm_deg` inside the window
//!   [storm_start_s, storm_end_s) of the period (systole and the time around it) and `calm_deg`
//!   outside it. `scripted` uses [`Scripted::TUNED`]; `scripted:CALM:STORM:START:END` names the
//!   four parameters (commas work too, but colons keep the name one CSV field);
//! - `scripted-heading:CALM:STORM:START:END` (privileged): the same switch between two
//!   `heading:DEG` directions, one for every member (the one-wall family of `heading`).

use std::str::FromStr;

use crate::rng::Rng;

/// The phase-switched wall-angle controller's parameters (angles in degrees from upstream
/// towards the nearer wall, window ends in seconds of the waveform period; the window may wrap
/// past the period's end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scripted {
    /// Angle in the calm phase (deg from upstream towards the nearer wall).
    pub calm_deg: f64,
    /// Angle inside the storm window (deg from upstream towards the nearer wall).
    pub storm_deg: f64,
    /// Start of the storm window (s into the waveform period).
    pub storm_start_s: f64,
    /// End of the storm window (s into the waveform period); may be below the start (wraps).
    pub storm_end_s: f64,
}

impl Scripted {
    /// The parameters `scripted` runs with: the best of the direct search in
    /// docs/experiments.md ("The scripted controller"), on training seeds only.
    pub const TUNED: Scripted = Scripted {
        calm_deg: 40.0,
        storm_deg: 60.0,
        storm_start_s: 0.9,
        storm_end_s: 0.15,
    };

    /// Whether the waveform time `t_s` (s since phase 0) falls in the storm window.
    pub fn in_storm(&self, t_s: f64, period_s: f64) -> bool {
        let since = (t_s - self.storm_start_s).rem_euclid(period_s);
        let width = (self.storm_end_s - self.storm_start_s).rem_euclid(period_s);
        since < width
    }

    /// The angle (deg) at waveform time `t_s`: `storm_deg` in the window, `calm_deg` outside.
    pub fn angle(&self, t_s: f64, period_s: f64) -> f64 {
        if self.in_storm(t_s, period_s) {
            self.storm_deg
        } else {
            self.calm_deg
        }
    }

    /// The four parameters as a name takes them, `CALM:STORM:START:END`.
    fn spec(&self) -> String {
        format!(
            "{}:{}:{}:{}",
            self.calm_deg, self.storm_deg, self.storm_start_s, self.storm_end_s
        )
    }

    /// Parses `CALM:STORM:START:END` given after `family:` (`scripted` or `scripted-heading`),
    /// whose name the errors quote.
    fn parse(family: &str, spec: &str) -> Result<Self, String> {
        let values: Vec<f64> = spec
            .split([',', ':'])
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("`{family}:{spec}`: the four parameters must be numbers"))?;
        let [calm_deg, storm_deg, storm_start_s, storm_end_s] = values[..] else {
            return Err(format!(
                "`{family}:{spec}`: give four numbers, {family}:CALM_DEG:STORM_DEG:START_S:END_S"
            ));
        };
        if !values.iter().all(|v| v.is_finite()) {
            return Err(format!("`{family}:{spec}`: the parameters must be finite"));
        }
        Ok(Self {
            calm_deg,
            storm_deg,
            storm_start_s,
            storm_end_s,
        })
    }
}

/// A non-learned controller, parsed from the `rollout --policy` name.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Controller {
    /// a = (-1, 0): full thrust against the flow.
    Upstream,
    /// a = (-1/sqrt2, +-1/sqrt2): upstream and towards the nearer wall.
    Wall,
    /// a = 0: no thrust.
    Zero,
    /// Each action component uniform in [-1, 1].
    Random,
    /// Full thrust at the given angle (deg) from upstream towards the nearer wall.
    WallAngle(f64),
    /// Full thrust at the given angle (deg) from upstream towards the upper wall (y = H),
    /// the same for every member.
    Heading(f64),
    /// Phase-switched wall-angle controller (reads the inlet phase).
    Scripted(Scripted),
    /// Phase-switched heading controller (reads the inlet phase): the angles of [`Scripted`]
    /// are headings, from upstream towards the upper wall for every member.
    ScriptedHeading(Scripted),
}

const NAMES: &str = "upstream, wall, wall-angle:DEG, heading:DEG, zero, random, scripted, \
                     scripted:CALM_DEG:STORM_DEG:START_S:END_S or \
                     scripted-heading:CALM_DEG:STORM_DEG:START_S:END_S";

impl FromStr for Controller {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(deg) = s.strip_prefix("wall-angle:") {
            return parse_deg(deg).map(Controller::WallAngle).ok_or_else(|| {
                format!("`{s}`: the angle must be a number of degrees, e.g. wall-angle:30")
            });
        }
        if let Some(deg) = s.strip_prefix("heading:") {
            return parse_deg(deg).map(Controller::Heading).ok_or_else(|| {
                format!(
                    "`{s}`: the heading must be a number of degrees from upstream towards the \
                     upper wall, e.g. heading:40 (heading:-40 towards the lower wall)"
                )
            });
        }
        if let Some(spec) = s.strip_prefix("scripted:") {
            return Scripted::parse("scripted", spec).map(Controller::Scripted);
        }
        if let Some(spec) = s.strip_prefix("scripted-heading:") {
            return Scripted::parse("scripted-heading", spec).map(Controller::ScriptedHeading);
        }
        match s {
            "upstream" => Ok(Controller::Upstream),
            "wall" => Ok(Controller::Wall),
            "zero" => Ok(Controller::Zero),
            "random" => Ok(Controller::Random),
            "scripted" => Ok(Controller::Scripted(Scripted::TUNED)),
            other => Err(format!("unknown policy `{other}`: use {NAMES}")),
        }
    }
}

/// A finite number of degrees (`wall-angle:DEG`, `heading:DEG`), or None.
fn parse_deg(deg: &str) -> Option<f64> {
    deg.trim().parse::<f64>().ok().filter(|d| d.is_finite())
}

/// Thrust at `deg` degrees from upstream (-x) towards the upper wall (y = H), wherever the
/// member is.
fn heading(deg: f64) -> [f32; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    [-c as f32, s as f32]
}

/// Thrust at `deg` degrees from upstream (-x) towards the nearer wall.
fn towards_wall(deg: f64, obs: &[f32]) -> [f32; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    let y = if obs[1] < 0.0 { -s } else { s };
    [-c as f32, y as f32]
}

impl Controller {
    /// The name `rollout --policy` takes (parameters included).
    pub fn name(&self) -> String {
        match self {
            Controller::Upstream => "upstream".into(),
            Controller::Wall => "wall".into(),
            Controller::Zero => "zero".into(),
            Controller::Random => "random".into(),
            Controller::WallAngle(d) => format!("wall-angle:{d}"),
            Controller::Heading(d) => format!("heading:{d}"),
            Controller::Scripted(p) => format!("scripted:{}", p.spec()),
            Controller::ScriptedHeading(p) => format!("scripted-heading:{}", p.spec()),
        }
    }

    /// Whether the controller reads the inlet phase (information no learner observes).
    pub fn privileged(&self) -> bool {
        matches!(
            self,
            Controller::Scripted(_) | Controller::ScriptedHeading(_)
        )
    }

    /// Raw action of one agent from its observation and its environment's waveform time
    /// `t_s` (time since reset plus the start phase, s) in a waveform of period `period_s`.
    pub fn act(&self, obs: &[f32], t_s: f64, period_s: f64, rng: &mut Rng) -> [f32; 2] {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        match self {
            Controller::Upstream => [-1.0, 0.0],
            Controller::Wall => {
                if obs[1] < 0.0 {
                    [-s, -s]
                } else {
                    [-s, s]
                }
            }
            Controller::Zero => [0.0, 0.0],
            Controller::Random => [rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32],
            Controller::WallAngle(deg) => towards_wall(*deg, obs),
            Controller::Heading(deg) => heading(*deg),
            Controller::Scripted(p) => towards_wall(p.angle(t_s, period_s), obs),
            Controller::ScriptedHeading(p) => heading(p.angle(t_s, period_s)),
        }
    }

    /// Actions for every agent of every environment, `[E][N]`, from observations `[E][N][8]` and
    /// each environment's waveform time `t_s[e]`.
    pub fn act_all(&self, obs: &[f32], t_s: &[f64], period_s: f64, rng: &mut Rng) -> Vec<[f32; 2]> {
        let agents = (obs.len() / super::OBS_DIM / t_s.len().max(1)).max(1);
        obs.chunks(super::OBS_DIM)
            .enumerate()
            .map(|(k, o)| self.act(o, t_s[k / agents], period_s, rng))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOW: [f32; 8] = [0.0, -0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    const HIGH: [f32; 8] = [0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

    #[test]
    fn baselines_act_as_specified() {
        let mut rng = Rng::new(1);
        let act = |c: Controller, o: &[f32], rng: &mut Rng| c.act(o, 0.0, 1.0, rng);
        assert_eq!(act(Controller::Upstream, &LOW, &mut rng), [-1.0, 0.0]);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert_eq!(act(Controller::Wall, &LOW, &mut rng), [-s, -s]);
        assert_eq!(act(Controller::Wall, &HIGH, &mut rng), [-s, s]);
        assert_eq!(act(Controller::Zero, &LOW, &mut rng), [0.0, 0.0]);
        let a = act(Controller::Random, &LOW, &mut rng);
        assert!(a.iter().all(|x| (-1.0..1.0).contains(x)));
        assert_eq!("wall".parse::<Controller>(), Ok(Controller::Wall));
        assert!("best".parse::<Controller>().is_err());
    }

    #[test]
    fn wall_angle_spans_upstream_to_the_nearer_wall() {
        let a = |deg: f64, o: &[f32]| Controller::WallAngle(deg).act(o, 0.0, 1.0, &mut Rng::new(1));
        assert_eq!(a(0.0, &LOW), [-1.0, -0.0]);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        for (got, want) in a(45.0, &HIGH).iter().zip([-s, s]) {
            assert!((got - want).abs() < 1e-7, "{got} vs {want}");
        }
        // 60 degrees: (-1/2, -sqrt3/2) towards the lower wall, unit norm.
        let v = a(60.0, &LOW);
        assert!((v[0] + 0.5).abs() < 1e-7 && (v[1] + 0.75f32.sqrt()).abs() < 1e-7);
        assert_eq!(a(90.0, &HIGH)[1], 1.0);
        assert_eq!(
            "wall-angle:30".parse::<Controller>(),
            Ok(Controller::WallAngle(30.0))
        );
        assert!("wall-angle:x".parse::<Controller>().is_err());
    }

    #[test]
    fn heading_is_one_direction_for_every_member() {
        let a = |deg: f64, o: &[f32]| Controller::Heading(deg).act(o, 0.0, 1.0, &mut Rng::new(1));
        // 30 degrees towards the upper wall: (-sqrt3/2, 1/2), on either side of the centreline.
        for o in [&LOW, &HIGH] {
            let v = a(30.0, o);
            assert!((v[0] + 0.75f32.sqrt()).abs() < 1e-7 && (v[1] - 0.5).abs() < 1e-7);
        }
        // Negative: towards the lower wall, even for a member in the upper half.
        let v = a(-60.0, &HIGH);
        assert!((v[0] + 0.5).abs() < 1e-7 && (v[1] + 0.75f32.sqrt()).abs() < 1e-7);
        assert_eq!(a(0.0, &HIGH), [-1.0, 0.0]);
        let c: Controller = "heading:-40".parse().unwrap();
        assert_eq!(c, Controller::Heading(-40.0));
        assert_eq!(c.name(), "heading:-40");
        assert!(!c.privileged());
        let err = "heading:up".parse::<Controller>().unwrap_err();
        assert!(err.contains("heading:40"), "{err}");
    }

    #[test]
    fn angles_must_be_finite_numbers_of_degrees() {
        assert_eq!(
            " 12.5 ".parse::<Controller>().ok(),
            None,
            "a bare number is no controller"
        );
        assert_eq!(
            "heading: 12.5".parse::<Controller>(),
            Ok(Controller::Heading(12.5))
        );
        for bad in ["inf", "-inf", "NaN", ""] {
            let err = format!("wall-angle:{bad}")
                .parse::<Controller>()
                .unwrap_err();
            assert!(err.contains("wall-angle:30"), "{err}");
            let err = format!("heading:{bad}").parse::<Controller>().unwrap_err();
            assert!(err.contains("heading:40"), "{err}");
        }
    }

    #[test]
    fn scripted_switches_with_the_phase_and_its_window_wraps() {
        let p = Scripted {
            calm_deg: 0.0,
            storm_deg: 90.0,
            storm_start_s: 0.9,
            storm_end_s: 0.2,
        };
        for (t, storm) in [
            (0.0, true),
            (0.19, true),
            (0.2, false),
            (0.5, false),
            (0.9, true),
            (1.95, true),
            (2.5, false),
        ] {
            assert_eq!(p.in_storm(t, 1.0), storm, "t = {t}");
            let a = Controller::Scripted(p).act(&LOW, t, 1.0, &mut Rng::new(1));
            let want = if storm { [-0.0, -1.0] } else { [-1.0, -0.0] };
            assert!((a[0] - want[0]).abs() < 1e-7 && (a[1] - want[1]).abs() < 1e-7);
        }
        let c: Controller = "scripted:10:80:0.95:0.15".parse().unwrap();
        assert_eq!("scripted:10,80,0.95,0.15".parse::<Controller>(), Ok(c));
        assert_eq!(
            c,
            Controller::Scripted(Scripted {
                calm_deg: 10.0,
                storm_deg: 80.0,
                storm_start_s: 0.95,
                storm_end_s: 0.15
            })
        );
        assert_eq!(c.name(), "scripted:10:80:0.95:0.15");
        assert!(c.privileged() && !Controller::Wall.privileged());
        assert_eq!(
            "scripted".parse::<Controller>(),
            Ok(Controller::Scripted(Scripted::TUNED))
        );
        assert!("scripted:1,2,3".parse::<Controller>().is_err());
    }

    #[test]
    fn scripted_heading_switches_one_direction_for_every_member() {
        let c: Controller = "scripted-heading:45:-30:0.9:0.2".parse().unwrap();
        let p = Scripted {
            calm_deg: 45.0,
            storm_deg: -30.0,
            storm_start_s: 0.9,
            storm_end_s: 0.2,
        };
        assert_eq!(c, Controller::ScriptedHeading(p));
        assert_eq!(c.name(), "scripted-heading:45:-30:0.9:0.2");
        assert!(c.privileged());
        let s = std::f32::consts::FRAC_1_SQRT_2;
        for o in [&LOW, &HIGH] {
            // Calm (t = 0.5): 45 degrees towards the upper wall, on either side of the centreline.
            let a = c.act(o, 0.5, 1.0, &mut Rng::new(1));
            assert!((a[0] + s).abs() < 1e-7 && (a[1] - s).abs() < 1e-7, "{a:?}");
            // Storm (t = 1.1, wrapped): 30 degrees towards the lower wall, (-sqrt3/2, -1/2).
            let a = c.act(o, 1.1, 1.0, &mut Rng::new(1));
            assert!(
                (a[0] + 0.75f32.sqrt()).abs() < 1e-7 && (a[1] + 0.5).abs() < 1e-7,
                "{a:?}"
            );
        }
        let err = "scripted-heading:1:2".parse::<Controller>().unwrap_err();
        assert!(err.contains("`scripted-heading:1:2`"), "{err}");
        assert!(err.contains("scripted-heading:CALM_DEG"), "{err}");
    }

    #[test]
    fn act_all_gives_each_environment_its_own_phase() {
        let c = Controller::Scripted(Scripted {
            calm_deg: 0.0,
            storm_deg: 90.0,
            storm_start_s: 0.0,
            storm_end_s: 0.5,
        });
        // Two environments of two agents each: env 0 in the storm, env 1 calm.
        let obs: Vec<f32> = [LOW, HIGH, LOW, HIGH].concat();
        let a = c.act_all(&obs, &[0.1, 0.7], 1.0, &mut Rng::new(1));
        assert_eq!(a.len(), 4);
        assert!(
            a[0][1] < -0.99 && a[1][1] > 0.99,
            "env 0 pushes to the walls: {a:?}"
        );
        assert!(
            a[2][0] < -0.99 && a[3][0] < -0.99,
            "env 1 pushes upstream: {a:?}"
        );
    }
}
