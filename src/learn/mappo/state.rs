//! Saving and restoring the learner in a checkpoint: parameters by name, both optimisers' moments
//! and step counts, the observation normaliser and the RNG (under `learner.`); and the policy
//! alone (the actor's parameters and the normaliser, the same names), for `policy.safetensors`.

use super::*;

impl Learner {
    /// Adds the learner's whole state under `learner.`: parameters by name, both optimisers'
    /// moments and step counts, the observation normaliser and the RNG.
    pub fn save_state(&self, archive: &mut Archive) -> Result<(), LearnError> {
        self.put_params(archive, "")?;
        for (tag, opt) in [("actor", &self.opt_actor), ("critic", &self.opt_critic)] {
            let len = opt.m.len();
            archive.put_f32(&format!("learner.adam.{tag}.m"), &[len], &opt.m);
            archive.put_f32(&format!("learner.adam.{tag}.v"), &[len], &opt.v);
            archive.put_u64(&format!("learner.adam.{tag}.t"), &[opt.t]);
        }
        self.put_normalizer(archive);
        archive.put_u64("learner.rng", &[self.rng.0]);
        archive.put_u64("learner.shape", &[self.agents as u64, self.obs_dim as u64]);
        archive.put_u64("learner.global_dim", &[self.global_dim as u64]);
        archive.put_u64("learner.actor_global", &[self.actor_global as u64]);
        Ok(())
    }

    /// Restores what [`Self::save_state`] wrote; the learner must have the same agents,
    /// observation size, normalisation setting and critic inputs.
    pub fn load_state(&mut self, archive: &Archive) -> Result<(), LearnError> {
        self.check_fits(archive)?;
        // Checkpoints written before the critic could read a global state have none.
        let saved = match archive.shape("learner.global_dim") {
            Some(_) => archive.u64("learner.global_dim", Some(1))?[0] as usize,
            None => 0,
        };
        if saved != self.global_dim {
            return Err(archive
                .mismatch(format!(
                    "its critic read {saved} global-state inputs (train.critic_phase = {}), this \
                     run's reads {} (train.critic_phase = {})",
                    saved > 0,
                    self.global_dim,
                    self.global_dim > 0
                ))
                .into());
        }
        // Read everything before changing anything, so a bad file leaves the learner intact.
        let vars = named_vars(&self.map, "");
        let params = read_params(archive, &vars)?;
        let mut opts = Vec::new();
        for (tag, opt) in [("actor", &self.opt_actor), ("critic", &self.opt_critic)] {
            let len = Some(opt.m.len());
            opts.push((
                archive.f32(&format!("learner.adam.{tag}.m"), len)?,
                archive.f32(&format!("learner.adam.{tag}.v"), len)?,
                archive.u64(&format!("learner.adam.{tag}.t"), Some(1))?[0],
            ));
        }
        let normalizer = self.read_normalizer(archive)?;
        let rng = archive.u64("learner.rng", Some(1))?[0];
        set_values(&vars, &params)?;
        for (opt, (m, v, t)) in [&mut self.opt_actor, &mut self.opt_critic]
            .into_iter()
            .zip(opts)
        {
            (opt.m, opt.v, opt.t) = (m, v, t);
        }
        self.actor_p = values(&self.actor_vars)?;
        self.critic_p = values(&self.critic_vars)?;
        self.normalizer = normalizer;
        self.rng.0 = rng;
        Ok(())
    }

    /// Adds what acting needs under the names [`Self::save_state`] uses: the actor's
    /// parameters, the observation normaliser and the shape (no critic, optimiser or RNG).
    pub fn save_policy(&self, archive: &mut Archive) -> Result<(), LearnError> {
        self.put_params(archive, "actor")?;
        self.put_normalizer(archive);
        archive.put_u64("learner.shape", &[self.agents as u64, self.obs_dim as u64]);
        archive.put_u64("learner.actor_global", &[self.actor_global as u64]);
        Ok(())
    }

    /// Restores the policy (the actor and the normaliser) from a checkpoint or a policy file;
    /// the critic, the optimisers and the RNG stay as [`Learner::new`] made them, so a seed
    /// given to it drives the sampled actions.
    pub fn load_policy(&mut self, archive: &Archive) -> Result<(), LearnError> {
        self.check_fits(archive)?;
        let vars = named_vars(&self.map, "actor");
        let params = read_params(archive, &vars)?;
        let normalizer = self.read_normalizer(archive)?;
        set_values(&vars, &params)?;
        self.actor_p = values(&self.actor_vars)?;
        self.normalizer = normalizer;
        Ok(())
    }

    fn put_normalizer(&self, archive: &mut Archive) {
        if let Some(n) = &self.normalizer {
            archive.put_f64("learner.obs_norm.count", &[1], &[n.count]);
            archive.put_f64("learner.obs_norm.mean", &[n.dim()], &n.mean);
            archive.put_f64("learner.obs_norm.var", &[n.dim()], &n.var);
        }
    }

    fn read_normalizer(&self, archive: &Archive) -> Result<Option<ObsNormalizer>, LearnError> {
        Ok(match &self.normalizer {
            Some(n) => Some(ObsNormalizer {
                count: archive.f64("learner.obs_norm.count", Some(1))?[0],
                mean: archive.f64("learner.obs_norm.mean", Some(n.dim()))?,
                var: archive.f64("learner.obs_norm.var", Some(n.dim()))?,
            }),
            None => None,
        })
    }

    /// The archive was written for this learner's agents, observation size, actor inputs and
    /// normalisation.
    fn check_fits(&self, archive: &Archive) -> Result<(), LearnError> {
        let shape = archive.u64("learner.shape", Some(2))?;
        if shape != [self.agents as u64, self.obs_dim as u64] {
            return Err(archive
                .mismatch(format!(
                    "it was trained with {} agents and {} observations each, this run has {} and {}",
                    shape[0], shape[1], self.agents, self.obs_dim
                ))
                .into());
        }
        // Files written before the actor could read a global state have none.
        let actor_global = match archive.shape("learner.actor_global") {
            Some(_) => archive.u64("learner.actor_global", Some(1))?[0] as usize,
            None => 0,
        };
        if actor_global != self.actor_global {
            return Err(archive
                .mismatch(format!(
                    "its actor read {actor_global} global-state inputs (train.actor_phase = {}), \
                     this run's reads {} (train.actor_phase = {})",
                    actor_global > 0,
                    self.actor_global,
                    self.actor_global > 0
                ))
                .into());
        }
        let saved_norm = archive.shape("learner.obs_norm.mean").is_some();
        if saved_norm != self.normalizer.is_some() {
            return Err(archive
                .mismatch(format!(
                    "train.normalize_observations was {saved_norm} when it was written, {} now",
                    !saved_norm
                ))
                .into());
        }
        Ok(())
    }

    /// The parameters whose names start with `prefix`, as `learner.param.<name>`.
    fn put_params(&self, archive: &mut Archive, prefix: &str) -> Result<(), LearnError> {
        for (name, var) in named_vars(&self.map, prefix) {
            let data: Vec<f32> = var.as_tensor().flatten_all()?.to_vec1()?;
            archive.put_f32(&format!("learner.param.{name}"), var.dims(), &data);
        }
        Ok(())
    }
}

/// The saved values of `vars`, concatenated in their order.
fn read_params(archive: &Archive, vars: &[(String, Var)]) -> Result<Vec<f32>, LearnError> {
    let mut params = Vec::new();
    for (name, var) in vars {
        params.extend(archive.f32(&format!("learner.param.{name}"), Some(var.elem_count()))?);
    }
    Ok(params)
}
