//! The columns of SPEC section 7's other tables, in one place beside their writers' modules
//! (`episodes.csv` is [`super::episodes`]; `starts.csv`, `swarm.csv` and `trajectories.csv`
//! are [`super::traces`]). Scripts and `report` read these names.

/// `summary.csv` of `simulate`: one row per recorded step.
pub const SUMMARY_COLUMNS: &str =
    "step,t_s,inlet_u_m_s,max_div_per_s,flux_min_m2_s,flux_max_m2_s,pressure_iters,residual";

/// `updates.csv` of `train`: one row per update (losses, gradient cosines and conflicts, time).
pub const UPDATES_COLUMNS: &str = "update,global_step,loss_progress,loss_energy,loss_smoothness,value_loss,entropy,mean_log_std,cos_pe,cos_ps,cos_es,conflict_pe,conflict_ps,conflict_es,sim_s,learn_s";

/// `bench.csv` of `bench`: one row per batch size.
pub const BENCH_COLUMNS: &str = "envs,env_steps_per_s,cell_updates_per_s,dispatches_per_substep,pressure_iters_per_substep,fluid_s,pressure_s,swarm_s,readback_s,adapter";
