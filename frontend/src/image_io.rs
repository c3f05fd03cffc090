//! Reading the front-end's images with errors that name the file: OpenCV's `imread` returns an
//! empty matrix for a missing or undecodable file, which must not reach the pipeline.

use std::path::Path;

use opencv::core::{CV_8UC1, CV_16UC1, Mat};
use opencv::imgcodecs::{IMREAD_ANYDEPTH, IMREAD_GRAYSCALE, imread};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};

/// Reads `path` as an 8-bit grey image (colour PNGs are converted).
///
/// # Errors
/// Missing file, or a file that does not decode.
pub fn read_grey(path: &Path, what: &str) -> Result<Mat, FrontEndError> {
    read(path, what, IMREAD_GRAYSCALE, CV_8UC1, "an 8-bit image")
}

/// Reads `path` as a 16-bit single-channel PNG (depth maps, instance masks, KITTI disparity).
///
/// # Errors
/// Missing file, or a file that is not a 16-bit single-channel image.
pub fn read_u16(path: &Path, what: &str) -> Result<Mat, FrontEndError> {
    read(path, what, IMREAD_ANYDEPTH, CV_16UC1, "a 16-bit single-channel PNG")
}

fn read(path: &Path, what: &str, flags: i32, typ: i32, expected: &str) -> Result<Mat, FrontEndError> {
    if !path.is_file() {
        return Err(FrontEndError::Missing { path: path.to_path_buf(), what: what.to_string() });
    }
    let unreadable = || FrontEndError::Unreadable { path: path.to_path_buf(), expected: expected.to_string() };
    let name = path.to_str().ok_or_else(unreadable)?;
    // imread fails quietly (empty matrix) on a corrupt file; an OpenCV exception is the same.
    let m = imread(name, flags).map_err(|_| unreadable())?;
    if m.empty() || m.typ() != typ {
        return Err(unreadable());
    }
    Ok(m)
}

/// Checks that `m` (read from `path`) has the size of `reference` (read from `reference_name`).
///
/// # Errors
/// [`FrontEndError::SizeMismatch`] naming `path`.
pub fn same_size(m: &Mat, path: &Path, reference: &Mat, reference_name: &Path) -> Result<(), FrontEndError> {
    if m.cols() == reference.cols() && m.rows() == reference.rows() {
        return Ok(());
    }
    Err(FrontEndError::SizeMismatch {
        path: path.to_path_buf(),
        found_w: m.cols(),
        found_h: m.rows(),
        want_w: reference.cols(),
        want_h: reference.rows(),
        other: reference_name.display().to_string(),
    })
}

/// A grey `Mat` copied from a row-major 8-bit buffer.
///
/// # Errors
/// A buffer whose length is not `width * height`, or an OpenCV failure.
pub fn grey_from_buffer(data: &[u8], width: usize, height: usize) -> Result<Mat, FrontEndError> {
    mat_from(data, width, height, 1)
}

/// A 3-channel (BGR) `Mat` copied from a row-major RGB buffer.
///
/// # Errors
/// A buffer whose length is not `3 * width * height`, or an OpenCV failure.
pub fn bgr_from_rgb(data: &[u8], width: usize, height: usize) -> Result<Mat, FrontEndError> {
    let mut swapped = data.to_vec();
    for px in swapped.chunks_exact_mut(3) {
        px.swap(0, 2);
    }
    mat_from(&swapped, width, height, 3)
}

fn mat_from<T: opencv::core::DataType>(
    data: &[T],
    width: usize,
    height: usize,
    channels: usize,
) -> Result<Mat, FrontEndError> {
    let bad = |what: &str| FrontEndError::OpenCv {
        context: format!("image buffer: {what}"),
        source: opencv::Error::new(0, "bad size"),
    };
    if data.len() != width * height * channels || width == 0 || height == 0 {
        return Err(bad("length is not width x height x channels"));
    }
    let flat = Mat::from_slice(data).map_err(cv("wrapping a buffer"))?;
    let rows = i32::try_from(height).map_err(|_| bad("too tall"))?;
    let shaped =
        flat.reshape(i32::try_from(channels).map_err(|_| bad("channels"))?, rows).map_err(cv("reshaping a buffer"))?;
    shaped.try_clone().map_err(cv("copying a buffer"))
}

/// A 16-bit single-channel `Mat` copied from a row-major buffer (depth maps, masks).
///
/// # Errors
/// A buffer whose length is not `width * height`, or an OpenCV failure.
pub fn u16_from_buffer(data: &[u16], width: usize, height: usize) -> Result<Mat, FrontEndError> {
    mat_from(data, width, height, 1)
}
