//! Export: the model blob the core runs, and the training checkpoint.
//!
//! Blob: the 20 inference tensors of `dynotraj_core::model::arch` in layout order, each as
//! row-major f32 (candle's linear weights are [out, in] and its recurrent weights are PyTorch's
//! [gates * H, in] with gates (i, f, g, o) or (r, z, n): the layout's own convention, so no
//! reordering is needed), written by `dynotraj_core::model::blob::write_blob` in f32 or int8.
//!
//! Checkpoint (`.safetensors`): every variable of the network, inference and training-only,
//! under its PyTorch-style name (`enc.weight_ih_l0`, `gru.bias_hh_l0`, `future.weight_hh_l0_reverse`,
//! `qz.weight`, ...; see [`super::model`]), plus
//! - `meta.dims`: f32 [5] = enc, edge, k, dec, frame period in seconds;
//! - `meta.blob`: u8 [n], the f32 model blob of the same weights.
//!
//! [`load_checkpoint`] rebuilds the network from it (to resume, inspect or re-export).

use std::collections::HashMap;
use std::path::Path;

use candle_core::{DType, Device, Result, Tensor};
use candle_nn::VarMap;
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::{blob_len, write_blob, Precision};

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

/// The model blob of `net` in `precision` for frame period `dt`.
///
/// # Errors
/// `dims` other than the network's; a tensor whose size disagrees with the layout or a
/// non-finite weight (reported by the blob writer).
pub fn to_blob(net: &Network, dims: &Dims, precision: Precision, dt: f32) -> Result<Vec<u8>> {
    if *dims != net.dims {
        candle_core::bail!("network widths {:?} differ from the requested {dims:?}", net.dims);
    }
    let tensors = layout_tensors(net)?;
    let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
    let mut buf = vec![0u8; blob_len(dims, precision)];
    write_blob(dims, precision, dt, &slices, &mut buf).map_err(|e| candle_core::Error::Msg(format!("writing the model blob: {e}")))?;
    Ok(buf)
}

/// Writes the checkpoint of `net` (variables `vars`, frame period `dt`) to `path`.
///
/// # Errors
/// I/O errors; see [`to_blob`].
pub fn save_checkpoint(net: &Network, vars: &VarMap, dt: f32, path: &Path) -> Result<()> {
    let mut all: HashMap<String, Tensor> = {
        let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
        data.iter().map(|(k, v)| (k.clone(), v.as_tensor().clone())).collect()
    };
    let Dims { enc, edge, k, dec } = net.dims;
    all.insert("meta.dims".into(), Tensor::new(&[enc as f32, edge as f32, k as f32, dec as f32, dt], &Device::Cpu)?);
    let blob = to_blob(net, &net.dims, Precision::F32, dt)?;
    all.insert("meta.blob".into(), Tensor::from_vec(blob.clone(), blob.len(), &Device::Cpu)?);
    candle_core::safetensors::save(&all, path)
}

/// Reads a checkpoint written by [`save_checkpoint`]: the network, its variables and the frame
/// period.
///
/// # Errors
/// I/O errors, a missing variable or a shape that disagrees with `meta.dims`.
pub fn load_checkpoint(path: &Path) -> Result<(Network, VarMap, f32)> {
    let saved = candle_core::safetensors::load(path, &Device::Cpu)?;
    let meta = saved.get("meta.dims").ok_or_else(|| candle_core::Error::Msg("checkpoint has no meta.dims".into()))?.to_dtype(DType::F32)?.to_vec1::<f32>()?;
    let [enc, edge, k, dec, dt] = meta[..] else { candle_core::bail!("meta.dims holds {} values, expected 5", meta.len()) };
    let dims = Dims { enc: enc as usize, edge: edge as usize, k: k as usize, dec: dec as usize };
    let (net, vars) = Network::new(dims, 0)?;
    {
        let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
        for (name, var) in data.iter() {
            let t = saved.get(name).ok_or_else(|| candle_core::Error::Msg(format!("checkpoint has no {name}")))?;
            var.set(t)?;
        }
    }
    Ok((net, vars, dt))
}
