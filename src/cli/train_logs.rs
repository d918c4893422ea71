//! The log files of a `train` run (`train`'s module header): `episodes.csv` and `updates.csv`
//! (SPEC section 7) and the TensorBoard event file, created for a fresh run, reopened and cut
//! back to its checkpoint for a resumed one, and appended to after every update.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use fluxswarm_gpu::checkpoint::Archive;
use fluxswarm_gpu::env::Outcome;
use fluxswarm_gpu::learn::mappo::Iteration;
use fluxswarm_gpu::output::episodes::EpisodesCsv;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::output::tables;
use fluxswarm_gpu::output::tensorboard::EventWriter;

/// The run's open log files.
pub(super) struct Logs {
    pub(super) episodes: EpisodesCsv,
    pub(super) updates: std::io::BufWriter<std::fs::File>,
    pub(super) events: EventWriter,
}

/// Creates the logs of a fresh run in `out`.
pub(super) fn create_logs(out: &Path) -> anyhow::Result<Logs> {
    let episodes = EpisodesCsv::create(out, true).context("creating episodes.csv")?;
    let f = std::fs::File::create(out.join("updates.csv")).context("creating updates.csv")?;
    let mut updates = std::io::BufWriter::new(f);
    writeln!(updates, "{}", tables::UPDATES_COLUMNS)?;
    updates.flush()?;
    let events = EventWriter::create(out).context("creating the TensorBoard event file")?;
    Ok(Logs {
        episodes,
        updates,
        events,
    })
}

/// Reopens the logs of a resumed run, cut back to what its checkpoint `archive` covers.
pub(super) fn reopen_logs(out: &Path, archive: &Archive) -> anyhow::Result<Logs> {
    let cut = |key: &str| archive.meta_parse::<u64>(key);
    let episodes = EpisodesCsv::resume(out, true, cut("episodes_csv_bytes")?)
        .context("reopening episodes.csv")?;
    let f = run_dir::append_after(&out.join("updates.csv"), cut("updates_csv_bytes")?)
        .context("reopening updates.csv")?;
    let events = EventWriter::resume(
        &out.join(archive.meta("events_file")?),
        cut("events_bytes")?,
    )
    .context("reopening the TensorBoard event file")?;
    Ok(Logs {
        episodes,
        updates: std::io::BufWriter::new(f),
        events,
    })
}

/// Logs update `update` (ending at global step `global`): its episodes, its row of
/// `updates.csv` and the TensorBoard scalars.
pub(super) fn log_update(
    logs: &mut Logs,
    update: u64,
    global: u64,
    it: &Iteration,
) -> anyhow::Result<()> {
    for s in &it.episodes {
        logs.episodes.write(global, s)?;
        logs.events.scalars(
            global,
            &[
                ("episode/progress", s.progress as f32),
                ("episode/energy", s.energy as f32),
                ("episode/smoothness", s.smoothness as f32),
                ("episode/steps", s.steps as f32),
                (
                    "episode/success",
                    (s.outcome == Outcome::Success) as u8 as f32,
                ),
            ],
        )?;
    }
    let st = &it.stats;
    writeln!(
        logs.updates,
        "{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
        update,
        global,
        st.loss[0],
        st.loss[1],
        st.loss[2],
        st.value_loss,
        st.entropy,
        st.mean_log_std,
        st.cosine[0],
        st.cosine[1],
        st.cosine[2],
        st.conflict[0],
        st.conflict[1],
        st.conflict[2],
        it.sim_s,
        it.learn_s
    )?;
    logs.updates.flush()?;
    let scalars: Vec<(&str, f32)> = [
        ("loss/progress", st.loss[0]),
        ("loss/energy", st.loss[1]),
        ("loss/smoothness", st.loss[2]),
        ("loss/value", st.value_loss),
        ("policy/entropy", st.entropy),
        ("policy/mean_log_std", st.mean_log_std),
        ("pcgrad/cos_pe", st.cosine[0]),
        ("pcgrad/cos_ps", st.cosine[1]),
        ("pcgrad/cos_es", st.cosine[2]),
        ("pcgrad/conflict_pe", st.conflict[0]),
        ("pcgrad/conflict_ps", st.conflict[1]),
        ("pcgrad/conflict_es", st.conflict[2]),
        ("time/sim_s", it.sim_s),
        ("time/learn_s", it.learn_s),
    ]
    .into_iter()
    .map(|(k, v)| (k, v as f32))
    .collect();
    logs.events.scalars(global, &scalars)?;
    Ok(())
}
