//! Files a run writes (SPEC section 7): frames, `.npy` fields, CSV tables, run directories.

pub mod episodes;
pub mod frame;
pub mod gif;
pub mod npy;
pub mod run_dir;
pub mod tables;
pub mod tensorboard;
pub mod text;
pub mod traces;
