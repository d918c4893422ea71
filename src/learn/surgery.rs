//! Flat views of candle parameters and gradients: a `GradStore` (the critic's backward pass,
//! the autograd references of the actor's tests) flattened per variable in name order (a
//! `VarMap` iterates a HashMap, so names fix the order), the vector PCGrad
//! ([`super::pcgrad`]) and Adam work on, and its way back into the variables or a `GradStore`.

use candle_core::backprop::GradStore;
use candle_core::{Result, Tensor, Var};
use candle_nn::VarMap;

/// The variables of `map` whose names start with `prefix`, sorted by name.
pub fn named_vars(map: &VarMap, prefix: &str) -> Vec<(String, Var)> {
    let data = map.data().lock().expect("var map lock");
    let mut vars: Vec<(String, Var)> = data
        .iter()
        .filter(|(k, _)| k.starts_with(prefix))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    vars.sort_by(|a, b| a.0.cmp(&b.0));
    vars
}

/// The gradient of every variable in order, flattened (zeros where a variable has none).
pub fn flatten(grads: &GradStore, vars: &[(String, Var)]) -> Result<Vec<f32>> {
    let mut out = Vec::new();
    for (_, v) in vars {
        match grads.get(v.as_tensor()) {
            Some(g) => out.extend(
                g.flatten_all()?
                    .to_dtype(candle_core::DType::F32)?
                    .to_vec1::<f32>()?,
            ),
            None => out.extend(std::iter::repeat_n(0.0, v.elem_count())),
        }
    }
    Ok(out)
}

/// The values of the variables in order, flattened.
pub fn values(vars: &[(String, Var)]) -> Result<Vec<f32>> {
    let mut out = Vec::new();
    for (_, v) in vars {
        out.extend(
            v.as_tensor()
                .flatten_all()?
                .to_dtype(candle_core::DType::F32)?
                .to_vec1::<f32>()?,
        );
    }
    Ok(out)
}

/// `flat` split back over the variables in order, one tensor of each variable's shape.
fn split(flat: &[f32], vars: &[(String, Var)]) -> Result<Vec<Tensor>> {
    let mut out = Vec::with_capacity(vars.len());
    let mut at = 0;
    for (_, v) in vars {
        let n = v.elem_count();
        out.push(
            Tensor::from_slice(&flat[at..at + n], v.shape(), v.device())?.to_dtype(v.dtype())?,
        );
        at += n;
    }
    assert_eq!(at, flat.len(), "flat length does not match the variables");
    Ok(out)
}

/// Overwrites the variables in order from one flat vector (the inverse of [`values`]).
pub fn set_values(vars: &[(String, Var)], flat: &[f32]) -> Result<()> {
    for ((_, v), t) in vars.iter().zip(split(flat, vars)?) {
        v.set(&t)?;
    }
    Ok(())
}

/// A `GradStore` holding `flat` split back over the variables.
pub fn unflatten(flat: &[f32], vars: &[(String, Var)]) -> Result<GradStore> {
    let mut store = GradStore::default();
    for ((_, v), t) in vars.iter().zip(split(flat, vars)?) {
        store.insert(v.as_tensor(), t);
    }
    Ok(store)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::pcgrad;
    use candle_core::{DType, Device};
    use candle_nn::{Module, Optimizer, VarBuilder};

    #[test]
    fn three_objective_surgery_round_trips_through_grad_stores() {
        let dev = Device::Cpu;
        let map = VarMap::new();
        let vb = VarBuilder::from_varmap(&map, DType::F32, &dev);
        let net = candle_nn::linear(3, 2, vb.pp("actor")).unwrap();
        let x = Tensor::new(&[[1.0f32, -2.0, 0.5], [0.3, 0.1, -1.0]], &dev).unwrap();
        let y = net.forward(&x).unwrap();
        // Three objectives that pull the outputs in different directions.
        let losses = [
            y.sum_all().unwrap(),
            y.sum_all()
                .unwrap()
                .neg()
                .unwrap()
                .affine(1.0, 0.0)
                .unwrap(),
            y.narrow(1, 0, 1).unwrap().sqr().unwrap().sum_all().unwrap(),
        ];
        let vars = named_vars(&map, "actor");
        assert_eq!(
            vars.iter().map(|v| v.0.as_str()).collect::<Vec<_>>(),
            ["actor.bias", "actor.weight"]
        );
        let flats: Vec<Vec<f32>> = losses
            .iter()
            .map(|l| flatten(&l.backward().unwrap(), &vars).unwrap())
            .collect();
        assert_eq!(flats[0].len(), 2 + 6);
        let s = pcgrad::pcgrad(&flats, &[vec![1, 2], vec![2, 0], vec![0, 1]]);
        assert!(s.conflicts[0], "objectives 0 and 1 are opposite");
        let store = unflatten(&s.combined, &vars).unwrap();
        assert_eq!(flatten(&store, &vars).unwrap(), s.combined);
        // The optimiser steps with the combined gradient.
        let before = values(&vars).unwrap();
        let mut opt = candle_nn::SGD::new(vars.iter().map(|v| v.1.clone()).collect(), 0.1).unwrap();
        opt.step(&store).unwrap();
        let after = values(&vars).unwrap();
        for k in 0..before.len() {
            assert!((after[k] - (before[k] - 0.1 * s.combined[k])).abs() < 1e-6);
        }
    }
}
