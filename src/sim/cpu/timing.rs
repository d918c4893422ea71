//! Optional per-stage timing of the CPU control step, for `bench`: a [`StageTimes`]
//! accumulator (nanoseconds per [`CpuStage`]) that [`super::BatchState::step_timed`] fills, one
//! per environment, and the `StageClock` that `step_env` laps after each stage call. Untimed
//! steps carry no clock (`None`): a lap is then one branch, and no clock is ever read. Timing
//! reads only the clock, never the state, so timed and untimed steps are bit-identical.

use std::ops::{AddAssign, Index};
use std::time::Instant;

/// The stages of the CPU substep (and the control step's closing diagnostics), in the order
/// `step_env` runs them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CpuStage {
    /// The members painted into the body field (with a swarm).
    Paint,
    /// Diffusion and advection, the inlet and the Brinkman blend (u*).
    Advect,
    /// div u*, its column maxima and its y-modes.
    PressureRhs,
    /// The tridiagonal sweeps of every mode.
    PressureSolve,
    /// The pressure from its modes.
    PressureBack,
    /// u = u* - dt/rho grad p, and u* copied back into the state.
    Project,
    /// The members forced and moved (with a swarm).
    Move,
    /// The health of the environment, once per control step.
    Diagnostics,
}

impl CpuStage {
    /// Number of stages.
    pub const COUNT: usize = 8;
    /// Every stage, in the order `step_env` runs them.
    pub const ALL: [CpuStage; Self::COUNT] = [
        CpuStage::Paint,
        CpuStage::Advect,
        CpuStage::PressureRhs,
        CpuStage::PressureSolve,
        CpuStage::PressureBack,
        CpuStage::Project,
        CpuStage::Move,
        CpuStage::Diagnostics,
    ];

    /// The stage's name in `bench`'s tables.
    pub fn name(self) -> &'static str {
        match self {
            CpuStage::Paint => "paint",
            CpuStage::Advect => "advect",
            CpuStage::PressureRhs => "pressure_rhs",
            CpuStage::PressureSolve => "pressure_solve",
            CpuStage::PressureBack => "pressure_back",
            CpuStage::Project => "project",
            CpuStage::Move => "move",
            CpuStage::Diagnostics => "diagnostics",
        }
    }

    /// Position of the stage in [`CpuStage::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Time spent in each stage (ns), summed over the substeps of the steps timed (and, after
/// [`StageTimes::add_assign`], over environments: CPU time, not wall time).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageTimes {
    /// Nanoseconds per stage, indexed by [`CpuStage::index`].
    pub ns: [u64; CpuStage::COUNT],
}

impl StageTimes {
    /// Seconds in `stage`.
    pub fn seconds(&self, stage: CpuStage) -> f64 {
        self.ns[stage.index()] as f64 * 1e-9
    }

    /// Seconds over all stages.
    pub fn total_seconds(&self) -> f64 {
        self.ns.iter().sum::<u64>() as f64 * 1e-9
    }
}

impl Index<CpuStage> for StageTimes {
    type Output = u64;
    fn index(&self, stage: CpuStage) -> &u64 {
        &self.ns[stage.index()]
    }
}

impl AddAssign for StageTimes {
    fn add_assign(&mut self, other: Self) {
        for (a, b) in self.ns.iter_mut().zip(other.ns) {
            *a += b;
        }
    }
}

impl std::iter::Sum for StageTimes {
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        let mut total = Self::default();
        for t in iter {
            total += t;
        }
        total
    }
}

/// The clock of one environment's timed step: each [`Self::lap`] charges the time since the
/// previous lap (or the start) to a stage. Without times it does nothing.
pub(crate) struct StageClock<'a> {
    timed: Option<(&'a mut StageTimes, Instant)>,
}

impl<'a> StageClock<'a> {
    pub fn start(times: Option<&'a mut StageTimes>) -> Self {
        Self {
            timed: times.map(|t| (t, Instant::now())),
        }
    }

    #[inline(always)]
    pub fn lap(&mut self, stage: CpuStage) {
        if let Some((times, last)) = &mut self.timed {
            let now = Instant::now();
            times.ns[stage.index()] += now.duration_since(*last).as_nanos() as u64;
            *last = now;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_are_listed_in_index_order_with_distinct_names() {
        for (k, s) in CpuStage::ALL.iter().enumerate() {
            assert_eq!(s.index(), k);
        }
        let mut names: Vec<_> = CpuStage::ALL.iter().map(|s| s.name()).collect();
        names.dedup();
        assert_eq!(names.len(), CpuStage::COUNT);
    }

    #[test]
    fn a_clock_without_times_charges_nothing_and_laps_add_up() {
        StageClock::start(None).lap(CpuStage::Advect);
        let mut t = StageTimes::default();
        let mut clock = StageClock::start(Some(&mut t));
        std::thread::sleep(std::time::Duration::from_millis(2));
        clock.lap(CpuStage::Advect);
        clock.lap(CpuStage::Project);
        assert!(t[CpuStage::Advect] >= 2_000_000, "{t:?}");
        let sum: StageTimes = [t, t].into_iter().sum();
        assert_eq!(sum[CpuStage::Advect], 2 * t[CpuStage::Advect]);
        assert!(
            (t.total_seconds() - t.seconds(CpuStage::Advect) - t.seconds(CpuStage::Project)).abs()
                < 1e-12
        );
    }
}
