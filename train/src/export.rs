//! Export: the model blob the core runs, and the training checkpoint.
//!
//! Blob: the 20 inference tensors of `dynotraj_core::model::arch` in layout order, each as
//! row-major f32 (candle's linear weights are [out, in] and its recurrent weights are PyTorch's
//! [gates * H, in] with gates (i, f, g, o) or (r, z, n): the layout's own convention, so no
//! reordering is needed), written by `dynotraj_core::model::blob::write_blob_with` in f32 or int8.
//!
//! Checkpoint (`.safetensors`): every variable of the network, inference and training-only,
//! under its PyTorch-style name (`enc.weight_ih_l0`, `gru.bias_hh_l0`, `future.weight_hh_l0_reverse`,
//! `qz.weight`, ...; see [`super::model`]), plus
//! - `meta.dims`: f32 [5] = enc, edge, k, dec, frame period in seconds;
//! - `meta.prior`: f32 [6] = the motion prior's velocity window, trend window, accel gain, turn
//!   gain, accel decay, turn decay, carry percent;
//! - `meta.blob`: u8 [n], the f32 model blob of the same weights.
//!
//! [`load_checkpoint`] rebuilds the network from it (to resume, inspect or re-export).

use std::collections::HashMap;
use std::path::Path;

use candle_core::{DType, Device, Result, Tensor};
use candle_nn::VarMap;
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::{Precision, blob_len, write_blob_with};
use dynotraj_core::predict::{Dynamics, PriorSettings};

use super::cells::bias;
use super::model::Network;

/// The 20 inference tensors of `net` in layout order, flattened row-major.
///
/// # Errors
/// Tensor access errors.
pub fn layout_tensors(net: &Network) -> Result<Vec<Vec<f32>>> {
    let tensors: [&Tensor; 20] = [
        &net.enc.w_ih,
        &net.enc.w_hh,
        &net.enc.b_ih,
        &net.enc.b_hh,
        &net.edge.w_ih,
        &net.edge.w_hh,
        &net.edge.b_ih,
        &net.edge.b_hh,
        net.pz1.weight(),
        bias(&net.pz1)?,
        net.pz2.weight(),
        bias(&net.pz2)?,
        net.dec_init.weight(),
        bias(&net.dec_init)?,
        &net.gru.w_ih,
        &net.gru.w_hh,
        &net.gru.b_ih,
        &net.gru.b_hh,
        net.out.weight(),
        bias(&net.out)?,
    ];
    tensors.iter().map(|t| t.flatten_all()?.to_vec1::<f32>()).collect()
}

/// The model blob of `net` in `precision` for frame period `dt`, over motion prior `prior`.
///
/// # Errors
/// `dims` other than the network's; a tensor whose size disagrees with the layout or a
/// non-finite weight (reported by the blob writer).
pub fn to_blob(net: &Network, dims: &Dims, precision: Precision, dt: f32, prior: &PriorSettings) -> Result<Vec<u8>> {
    if *dims != net.dims {
        candle_core::bail!("network widths {:?} differ from the requested {dims:?}", net.dims);
    }
    let tensors = layout_tensors(net)?;
    let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
    let mut buf = vec![0u8; blob_len(dims, precision)];
    write_blob_with(dims, precision, dt, prior, net.dynamics, &slices, &mut buf)
        .map_err(|e| candle_core::Error::Msg(format!("writing the model blob: {e}")))?;
    Ok(buf)
}

/// Writes the checkpoint of `net` (variables `vars`, frame period `dt`, motion prior `prior`)
/// to `path`.
///
/// # Errors
/// I/O errors; see [`to_blob`].
pub fn save_checkpoint(net: &Network, vars: &VarMap, dt: f32, prior: &PriorSettings, path: &Path) -> Result<()> {
    let mut all: HashMap<String, Tensor> = {
        let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
        data.iter().map(|(k, v)| (k.clone(), v.as_tensor().clone())).collect()
    };
    let Dims { enc, edge, k, dec } = net.dims;
    all.insert("meta.dims".into(), Tensor::new(&[enc as f32, edge as f32, k as f32, dec as f32, dt], &Device::Cpu)?);
    let p = prior;
    let fields = [
        f32::from(p.velocity_window),
        f32::from(p.trend_window),
        p.accel_gain,
        p.turn_gain,
        p.accel_decay,
        p.turn_decay,
        f32::from(p.carry_percent),
    ];
    all.insert("meta.prior".into(), Tensor::new(&fields, &Device::Cpu)?);
    let blob = to_blob(net, &net.dims, Precision::F32, dt, prior)?;
    all.insert("meta.blob".into(), Tensor::from_vec(blob.clone(), blob.len(), &Device::Cpu)?);
    candle_core::safetensors::save(&all, path)
}

/// Reads a checkpoint written by [`save_checkpoint`]: the network, its variables, the frame
/// period and the motion prior.
///
/// # Errors
/// I/O errors, a missing variable, a shape that disagrees with `meta.dims`, prior settings out
/// of range.
pub fn load_checkpoint(path: &Path) -> Result<(Network, VarMap, f32, PriorSettings)> {
    let saved = candle_core::safetensors::load(path, &Device::Cpu)?;
    let meta = saved
        .get("meta.dims")
        .ok_or_else(|| candle_core::Error::Msg("checkpoint has no meta.dims".into()))?
        .to_dtype(DType::F32)?
        .to_vec1::<f32>()?;
    let [enc, edge, k, dec, dt] = meta[..] else {
        candle_core::bail!("meta.dims holds {} values, expected 5", meta.len())
    };
    let dims = Dims { enc: enc as usize, edge: edge as usize, k: k as usize, dec: dec as usize };
    let fields = saved
        .get("meta.prior")
        .ok_or_else(|| {
            candle_core::Error::Msg("checkpoint has no meta.prior (written before the motion prior)".into())
        })?
        .to_dtype(DType::F32)?
        .to_vec1::<f32>()?;
    // Six values in checkpoints written before the carry (none carried).
    let (values, carry) = match fields.split_at_checked(6) {
        Some((six, &[carry])) => (six, carry),
        _ => (&fields[..], 0.0),
    };
    let [vw, tw, accel_gain, turn_gain, accel_decay, turn_decay] = values[..] else {
        candle_core::bail!("meta.prior holds {} values, expected 7 (or 6)", fields.len())
    };
    let prior = PriorSettings {
        velocity_window: vw as u8,
        trend_window: tw as u8,
        accel_gain,
        turn_gain,
        accel_decay,
        turn_decay,
        carry_percent: carry as u8,
    };
    if !prior.is_valid() {
        candle_core::bail!("meta.prior is out of range: {prior:?}");
    }
    let (mut net, vars) = Network::new(dims, 0)?;
    // The dynamics are the blob header's (byte 7); a checkpoint without a blob is a unicycle's.
    if let Some(blob) = saved.get("meta.blob") {
        let code = blob.narrow(0, 7, 1)?.to_dtype(DType::U8)?.to_vec1::<u8>()?;
        net.dynamics = code
            .first()
            .and_then(|&c| Dynamics::from_code(c))
            .ok_or_else(|| candle_core::Error::Msg(format!("meta.blob holds an unknown dynamics code {code:?}")))?;
    }
    {
        let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
        for (name, var) in data.iter() {
            let t = saved.get(name).ok_or_else(|| candle_core::Error::Msg(format!("checkpoint has no {name}")))?;
            var.set(t)?;
        }
    }
    Ok((net, vars, dt, prior))
}

#[cfg(test)]
mod tests {
    use candle_core::Module as _;
    use candle_nn::VarBuilder;
    use candle_nn::rnn::{GRUConfig, GRUState, LSTMConfig, LSTMState, RNN as _};
    use dynotraj_core::geometry::{BevState, Point2};
    use dynotraj_core::limits::HORIZON;
    use dynotraj_core::model::LearnedPredictor;
    use dynotraj_core::model::arch::FEATURES;
    use dynotraj_core::model::blob::ModelBlob;
    use dynotraj_core::predict::Context;
    use dynotraj_core::predict::prior::plan;

    use super::*;
    use crate::batch::Batch;
    use dynotraj_core::model::features::FeatureScales;
    use dynotraj_core::predict::Predictor as _;

    use crate::dataset::sample_over;
    use crate::synthetic::constant_control_runs;

    const SMALL: Dims = Dims { enc: 8, edge: 6, k: 3, dec: 10 };

    /// `w x + b` over row-major `w` [rows, x.len()].
    fn affine(w: &[f32], b: &[f32], x: &[f32]) -> Vec<f32> {
        b.iter()
            .enumerate()
            .map(|(i, bi)| bi + w[i * x.len()..(i + 1) * x.len()].iter().zip(x).map(|(a, c)| a * c).sum::<f32>())
            .collect()
    }

    fn sig(x: f32) -> f32 {
        1.0 / (1.0 + (-x).exp())
    }

    /// PyTorch's LSTM step written out over the exported tensors.
    fn lstm_ref(t: &[Vec<f32>], x: &[f32], h: &[f32], c: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let (gi, gh) = (affine(&t[0], &t[2], x), affine(&t[1], &t[3], h));
        let g: Vec<f32> = gi.iter().zip(&gh).map(|(a, b)| a + b).collect();
        let n = h.len();
        let c1: Vec<f32> = (0..n).map(|j| sig(g[n + j]) * c[j] + sig(g[j]) * g[2 * n + j].tanh()).collect();
        let h1 = (0..n).map(|j| sig(g[3 * n + j]) * c1[j].tanh()).collect();
        (h1, c1)
    }

    /// PyTorch's GRU step written out over the exported tensors.
    fn gru_ref(t: &[Vec<f32>], x: &[f32], h: &[f32]) -> Vec<f32> {
        let (gi, gh) = (affine(&t[0], &t[2], x), affine(&t[1], &t[3], h));
        let n = h.len();
        (0..n)
            .map(|j| {
                let r = sig(gi[j] + gh[j]);
                let z = sig(gi[n + j] + gh[n + j]);
                let nn = (gi[2 * n + j] + r * gh[2 * n + j]).tanh();
                (1.0 - z) * nn + z * h[j]
            })
            .collect()
    }

    fn close(a: &[f32], b: &[f32], tol: f32) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() <= tol, "{a:?}\n{b:?}");
        }
    }

    fn values(n: usize, seed: f32) -> Vec<f32> {
        (0..n).map(|i| (i as f32 * 0.37 + seed).sin() * 0.8).collect()
    }

    #[test]
    fn cells_follow_candle_nn_and_a_hand_written_step_over_the_exported_tensors() {
        let (net, vars) = Network::new(SMALL, 7).unwrap();
        let t = layout_tensors(&net).unwrap();
        let vb = VarBuilder::from_varmap(&vars, DType::F32, &Device::Cpu);
        let dev = Device::Cpu;

        // History encoder: tensors 0..4 of the layout, candle-nn's names under "enc".
        let (x, h, c) = (values(FEATURES, 0.1), values(SMALL.enc, 0.7), values(SMALL.enc, 1.3));
        let xt = Tensor::from_vec(x.clone(), (1, FEATURES), &dev).unwrap();
        let (ht, ct) = (
            Tensor::from_vec(h.clone(), (1, SMALL.enc), &dev).unwrap(),
            Tensor::from_vec(c.clone(), (1, SMALL.enc), &dev).unwrap(),
        );
        let gx = net.enc.project(&xt.unsqueeze(1).unwrap()).unwrap().squeeze(1).unwrap();
        let (h1, c1) = net.enc.step(&gx, &ht, &ct).unwrap();
        let reference = candle_nn::lstm(FEATURES, SMALL.enc, LSTMConfig::default(), vb.pp("enc")).unwrap();
        let theirs = reference.step(&xt, &LSTMState::new(ht, ct)).unwrap();
        let (want_h, want_c) = lstm_ref(&t[0..4], &x, &h, &c);
        let row = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
        close(&row(&h1), &want_h, 1e-6);
        close(&row(&c1), &want_c, 1e-6);
        close(&row(&theirs.h), &want_h, 1e-6);
        close(&row(&theirs.c), &want_c, 1e-6);

        // Decoder GRU: tensors 14..18, candle-nn's names under "gru".
        let input = 2 + SMALL.k + SMALL.cond();
        let (x, h) = (values(input, 2.0), values(SMALL.dec, 3.0));
        let xt = Tensor::from_vec(x.clone(), (1, input), &dev).unwrap();
        let ht = Tensor::from_vec(h.clone(), (1, SMALL.dec), &dev).unwrap();
        let ours = net.gru.step(&net.gru.project_columns(&xt, 0, input).unwrap(), &ht).unwrap();
        let reference = candle_nn::gru(input, SMALL.dec, GRUConfig::default(), vb.pp("gru")).unwrap();
        let theirs = reference.step(&xt, &GRUState { h: ht }).unwrap();
        let want = gru_ref(&t[14..18], &x, &h);
        close(&row(&ours), &want, 1e-6);
        close(&row(&theirs.h), &want, 1e-6);

        // Linear layers: weight [out, in] then bias, e.g. the output layer (tensors 18, 19).
        let hin = Tensor::from_vec(h.clone(), (1, SMALL.dec), &dev).unwrap();
        close(&row(&net.out.forward(&hin).unwrap()), &affine(&t[18], &t[19], &h), 1e-6);
        for (tensor, (rows, cols)) in t.iter().zip(SMALL.tensors()) {
            assert_eq!(tensor.len(), rows * cols);
        }
    }

    /// The output layer (zero in a new network) set to small pseudo-random values, so the
    /// residual is not zero.
    fn with_random_output(vars: &VarMap) {
        let data = vars.data().lock().unwrap();
        for name in ["out.weight", "out.bias"] {
            let var = data.get(name).unwrap_or_else(|| panic!("no {name}"));
            let n = var.as_tensor().elem_count();
            let values: Vec<f32> = (0..n).map(|i| 0.3 * ((i as f32) * 1.7).sin()).collect();
            var.set(&Tensor::from_vec(values, var.as_tensor().shape(), &Device::Cpu).unwrap()).unwrap();
        }
    }

    #[test]
    fn the_candle_forecast_is_what_core_computes_from_the_exported_blob() {
        for dynamics in Dynamics::ALL {
            let (mut net, vars) = Network::new(Dims::DEFAULT, 3).unwrap();
            net.dynamics = dynamics;
            with_random_output(&vars);
            candle_forecast_matches_core(&net);
        }
    }

    fn candle_forecast_matches_core(net: &Network) {
        let dt = 0.05;
        let prior = PriorSettings::DEFAULT;
        let blob = to_blob(net, &Dims::DEFAULT, Precision::F32, dt, &prior).unwrap();
        assert_eq!(ModelBlob::parse(&blob).unwrap().dynamics(), net.dynamics);
        let mut predictor = LearnedPredictor::new(ModelBlob::parse(&blob).unwrap());
        let runs = constant_control_runs(6, 40, dt, 5);
        for states in &runs {
            // A neighbour driving alongside, 5 m ahead and 3 m to the side.
            let beside: Vec<BevState> = states.iter().map(|s| BevState { x: s.x + 5.0, y: s.y - 3.0, ..*s }).collect();
            for s in [1usize, 3, 6, 8] {
                let neighbour = &beside[s.saturating_sub(4)..=s];
                let neighbours = [neighbour];
                let context = Context { neighbours: &neighbours, observer: Some(Point2::new(-12.0, 7.0)) };
                let scales = FeatureScales::of(net.dynamics);
                let sample = sample_over(states, s, HORIZON, &context, dt, 0, &prior, &scales).unwrap();
                let b = Batch::new(&[&sample], &Device::Cpu).unwrap();
                let ours = net.forecast(&b, dt).unwrap().to_vec3::<f32>().unwrap().remove(0);
                let mut core = [Point2::default(); HORIZON];
                predictor.predict_in_context(&states[..=s], &context, dt, &mut core).unwrap();
                let frame = plan(&states[..=s], &prior, dt).unwrap().frame;
                for (a, w) in ours.iter().zip(&core) {
                    let q = frame.to_agent(w);
                    assert!(
                        (a[0] - q.x).abs() < 1e-3 && (a[1] - q.y).abs() < 1e-3,
                        "{:?}: {a:?} vs {q:?}",
                        net.dynamics
                    );
                }
            }
        }
    }

    #[test]
    fn checkpoints_round_trip_and_carry_the_blob() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        let (mut net, vars) = Network::new(SMALL, 11).unwrap();
        net.dynamics = Dynamics::SingleIntegrator;
        let prior = PriorSettings { accel_gain: 0.75, ..PriorSettings::DEFAULT };
        save_checkpoint(&net, &vars, 0.1, &prior, &path).unwrap();
        let (back, _, dt, back_prior) = load_checkpoint(&path).unwrap();
        assert_eq!((back.dims, dt, back_prior, back.dynamics), (SMALL, 0.1, prior, Dynamics::SingleIntegrator));
        let blob = to_blob(&net, &SMALL, Precision::F32, 0.1, &prior).unwrap();
        assert_eq!(to_blob(&back, &SMALL, Precision::F32, 0.1, &prior).unwrap(), blob);
        let stored = candle_core::safetensors::load(&path, &Device::Cpu).unwrap();
        assert_eq!(stored["meta.blob"].to_vec1::<u8>().unwrap(), blob);
        assert!(
            stored.contains_key("qz.weight") && stored.contains_key("future.weight_hh_l0_reverse"),
            "training-only parts are kept"
        );
        assert!(ModelBlob::parse(&to_blob(&net, &SMALL, Precision::Int8, 0.1, &prior).unwrap()).is_ok());
        assert!(to_blob(&net, &Dims::DEFAULT, Precision::F32, 0.1, &prior).is_err(), "widths must match");
    }
}
