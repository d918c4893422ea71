//! Baseline policies (SPEC section 4) acting on one agent's observation: direct-upstream
//! (a = (-1, 0)), wall-hugging (a = (-1/sqrt2, +-1/sqrt2) towards the nearer wall), zero, and
//! uniform-random (each component uniform in [-1, 1]).

use std::str::FromStr;

use crate::rng::Rng;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Baseline {
    Upstream,
    Wall,
    Zero,
    Random,
}

impl FromStr for Baseline {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "upstream" => Ok(Baseline::Upstream),
            "wall" => Ok(Baseline::Wall),
            "zero" => Ok(Baseline::Zero),
            "random" => Ok(Baseline::Random),
            other => Err(format!(
                "unknown policy `{other}`: use upstream, wall, zero or random"
            )),
        }
    }
}

impl Baseline {
    pub fn name(&self) -> &'static str {
        match self {
            Baseline::Upstream => "upstream",
            Baseline::Wall => "wall",
            Baseline::Zero => "zero",
            Baseline::Random => "random",
        }
    }

    /// Raw action of one agent from its observation (obs[1] = (y - H/2) / (H/2)).
    pub fn act(&self, obs: &[f32], rng: &mut Rng) -> [f32; 2] {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        match self {
            Baseline::Upstream => [-1.0, 0.0],
            Baseline::Wall => {
                if obs[1] < 0.0 {
                    [-s, -s]
                } else {
                    [-s, s]
                }
            }
            Baseline::Zero => [0.0, 0.0],
            Baseline::Random => [rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32],
        }
    }

    /// Actions for every agent of every environment, [E][N], from observations [E][N][8].
    pub fn act_all(&self, obs: &[f32], rng: &mut Rng) -> Vec<[f32; 2]> {
        obs.chunks(super::OBS_DIM)
            .map(|o| self.act(o, rng))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn baselines_act_as_specified() {
        let mut rng = Rng::new(1);
        let low = [0.0, -0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let high = [0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(Baseline::Upstream.act(&low, &mut rng), [-1.0, 0.0]);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert_eq!(Baseline::Wall.act(&low, &mut rng), [-s, -s]);
        assert_eq!(Baseline::Wall.act(&high, &mut rng), [-s, s]);
        assert_eq!(Baseline::Zero.act(&low, &mut rng), [0.0, 0.0]);
        let a = Baseline::Random.act(&low, &mut rng);
        assert!(a.iter().all(|x| (-1.0..1.0).contains(x)));
        assert_eq!("wall".parse::<Baseline>(), Ok(Baseline::Wall));
        assert!("best".parse::<Baseline>().is_err());
    }
}
