//! Times one rollout + update of the learner on the CPU point-mass environment (no fluid), so
//! the learner's own cost shows: `cargo run --release --example learner_timing -- [E] [N] [reps]`
//! (`UNTUNED=1` skips [`fluxswarm_gpu::tuning::keep_freed_blocks`], to measure what it buys).
use std::time::Instant;

use fluxswarm_gpu::learn::env::{MultiAgentEnv, PointMasses};
use fluxswarm_gpu::learn::mappo::{Learner, TrainConfig};

fn main() -> anyhow::Result<()> {
    if std::env::var_os("UNTUNED").is_none() {
        fluxswarm_gpu::tuning::keep_freed_blocks();
    }
    let arg = |k: usize, d: usize| -> usize {
        std::env::args()
            .nth(k)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (e, n, reps) = (arg(1, 4), arg(2, 16), arg(3, 5));
    let mut env = PointMasses::new(e, n, 1);
    let mut learner = Learner::new(n, 8, TrainConfig::default(), 1)?;
    let mut obs = env.reset()?;
    learner.iterate(&mut env, &mut obs)?;
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = Instant::now();
        let it = learner.iterate(&mut env, &mut obs)?;
        times.push((t.elapsed().as_secs_f64(), it.learn_s, it.env_steps));
    }
    times.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (wall, learn, steps) = times[times.len() / 2];
    println!(
        "E={e} N={n}: median iteration {wall:.3} s, learner {learn:.3} s for {steps} env steps \
         ({:.2} ms per env step)",
        1e3 * learn / steps as f64
    );
    Ok(())
}
