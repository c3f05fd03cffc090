//! Model blobs on disk: read, validated, and lent to a predictor.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use dynotraj_core::model::LearnedPredictor;
use dynotraj_core::model::blob::ModelBlob;

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
    /// A missing or unreadable file, or a blob the core refuses (wrong version, widths, CRC...),
    /// with the path named.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("reading model blob {}", path.display()))?;
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
