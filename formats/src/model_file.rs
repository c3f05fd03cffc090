//! Model blobs on disk: read, validated, and lent to a predictor.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use dynotraj_core::model::Dims;
use dynotraj_core::model::LearnedPredictor;
use dynotraj_core::model::arch::{MAX_DEC, MAX_EDGE, MAX_ENC, MAX_K};
use dynotraj_core::model::blob::{ModelBlob, Precision, blob_len};
use dynotraj_core::model::signed::TRAILER_LEN;

/// The largest file a model can be: an f32 blob at the architecture's widest, signed.
pub const MAX_MODEL_FILE_BYTES: usize =
    blob_len(&Dims { enc: MAX_ENC, edge: MAX_EDGE, k: MAX_K, dec: MAX_DEC }, Precision::F32) + TRAILER_LEN;

/// Reads a model file (a blob or a signed blob), refusing one larger than any model can be
/// after at most that many bytes: a wrong path to a large file, a device or a pipe must not fill
/// memory.
///
/// # Errors
/// A missing or unreadable file, or one over [`MAX_MODEL_FILE_BYTES`], with the path named.
pub fn read_model_file(path: &Path) -> anyhow::Result<Vec<u8>> {
    crate::bounded::read_at_most(
        path,
        MAX_MODEL_FILE_BYTES as u64,
        "a model file (the largest model this build runs, signed)",
    )
}

/// A model blob read from a file and validated.
#[derive(Debug, Clone)]
pub struct ModelFile {
    path: PathBuf,
    bytes: Vec<u8>,
}

impl ModelFile {
    /// Reads and validates the blob at `path`.
    ///
    /// # Errors
    /// A missing or unreadable file, one larger than [`MAX_MODEL_FILE_BYTES`] (refused before
    /// it is read), or a blob the core refuses (wrong version, widths, CRC...), with the path named.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let bytes = read_model_file(path).context("model blob")?;
        ModelBlob::parse_exact(&bytes).map_err(|e| anyhow::anyhow!("model blob {}: {e}", path.display()))?;
        Ok(Self { path: path.to_path_buf(), bytes })
    }

    /// Wraps blob bytes already in memory (validated).
    ///
    /// # Errors
    /// A blob the core refuses.
    pub fn from_bytes(bytes: Vec<u8>, name: &str) -> anyhow::Result<Self> {
        ModelBlob::parse_exact(&bytes).map_err(|e| anyhow::anyhow!("model blob {name}: {e}"))?;
        Ok(Self { path: PathBuf::from(name), bytes })
    }

    /// Where it came from.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The blob bytes.
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The parsed blob.
    #[must_use]
    pub fn blob(&self) -> ModelBlob<'_> {
        // Validated on construction and immutable since, so parsing cannot fail here.
        ModelBlob::parse(&self.bytes).unwrap_or_else(|e| unreachable!("validated blob refused: {e}"))
    }

    /// A predictor reading this blob.
    #[must_use]
    pub fn predictor(&self) -> LearnedPredictor<'_> {
        LearnedPredictor::new(self.blob())
    }
}

/// The weights of a blob as f32 tensors in layout order (int8 weights dequantised), for
/// re-quantising or inspecting a model.
#[must_use]
pub fn float_tensors(blob: &ModelBlob<'_>) -> Vec<Vec<f32>> {
    use dynotraj_core::model::blob::{TensorView, f32_at};
    (0..dynotraj_core::model::arch::TENSORS)
        .filter_map(|i| blob.tensor(i))
        .map(|t| match t {
            TensorView::F32 { rows, cols, data } => (0..rows * cols).map(|j| f32_at(data, j)).collect(),
            TensorView::Int8 { rows, cols, scales, data } => {
                (0..rows * cols).map(|j| f32::from(data[j] as i8) * f32_at(scales, j / cols)).collect()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_larger_than_any_model_or_an_endless_device_is_refused_after_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.blob");
        // Sparse: 1 GiB on paper, nothing on disk or in memory.
        std::fs::File::create(&path).unwrap().set_len(1 << 30).unwrap();
        for path in [path.as_path(), Path::new("/dev/zero")] {
            for e in [
                format!("{:#}", read_model_file(path).unwrap_err()),
                format!("{:#}", ModelFile::load(path).unwrap_err()),
            ] {
                let expected = format!(
                    "expected a model file (the largest model this build runs, signed) of at most {MAX_MODEL_FILE_BYTES} bytes, found more"
                );
                assert!(e.contains(&path.display().to_string()) && e.contains(&expected), "{e}");
            }
        }
    }
}
