use super::*;

const SMALL: Dims = Dims { enc: 4, edge: 3, k: 2, dec: 5 };

/// Deterministic weights: tensor t, element j.
fn weights(dims: &Dims) -> [[f32; 4096]; TENSORS] {
    let mut w = [[0.0; 4096]; TENSORS];
    for (t, (rows, cols)) in dims.tensors().into_iter().enumerate() {
        for j in 0..rows * cols {
            w[t][j] = libm::sinf((t * 31 + j) as f32) * 0.5;
        }
    }
    w
}

fn write(dims: &Dims, precision: Precision, buf: &mut [u8]) -> usize {
    let w = weights(dims);
    let slices: [&[f32]; TENSORS] = core::array::from_fn(|t| {
        let (r, c) = dims.tensors()[t];
        &w[t][..r * c]
    });
    // Leak-free: the slices borrow `w`, which lives to the end of this call.
    write_blob(dims, precision, 0.05, &PriorSettings::DEFAULT, &slices, buf).unwrap()
}

#[test]
fn f32_and_int8_round_trip() {
    let mut buf = [0u8; 8192];
    for precision in [Precision::F32, Precision::Int8] {
        let n = write(&SMALL, precision, &mut buf);
        assert_eq!(n, blob_len(&SMALL, precision));
        let blob = ModelBlob::parse(&buf[..n]).unwrap();
        assert_eq!((blob.dims(), blob.precision(), blob.frame_period_s()), (SMALL, precision, 0.05));
        let w = weights(&SMALL);
        for (t, (rows, cols)) in SMALL.tensors().into_iter().enumerate() {
            match blob.tensor(t).unwrap() {
                TensorView::F32 { data, .. } => {
                    for j in 0..rows * cols {
                        assert_eq!(f32_at(data, j), w[t][j]);
                    }
                }
                TensorView::Int8 { scales, data, .. } => {
                    assert_eq!(precision, Precision::Int8);
                    for j in 0..rows * cols {
                        let s = f32_at(scales, j / cols);
                        let v = f32::from(data[j] as i8) * s;
                        assert!((v - w[t][j]).abs() <= 0.5 * s + 1e-7, "t {t} j {j}");
                    }
                }
            }
        }
        assert!(blob.tensor(TENSORS).is_none());
    }
    // Weights take a quarter of their f32 bytes; per-row scales and f32 biases weigh more in
    // small networks.
    let wide = Dims { enc: 32, edge: 32, k: 3, dec: 48 };
    assert!(blob_len(&wide, Precision::Int8) < blob_len(&wide, Precision::F32) / 3);
    assert!(blob_len(&Dims::DEFAULT, Precision::Int8) < blob_len(&Dims::DEFAULT, Precision::F32) / 2);
}

#[test]
fn an_exact_parse_refuses_bytes_after_the_blob() {
    let mut buf = [0u8; 8192];
    let n = write(&SMALL, Precision::Int8, &mut buf);
    assert!(ModelBlob::parse_exact(&buf[..n]).is_ok());
    assert_eq!(ModelBlob::parse_exact(&buf[..n + 1]).err(), Some(BlobError::Trailing { extra: 1 }));
    // A receive buffer larger than the blob is still fine for `parse`.
    assert!(ModelBlob::parse(&buf[..n + 100]).is_ok());
    assert!(matches!(ModelBlob::parse_exact(&buf[..n - 1]), Err(BlobError::TooShort { .. })));
}

#[test]
fn corrupt_or_mismatched_blobs_are_refused() {
    let mut buf = [0u8; 8192];
    let n = write(&SMALL, Precision::Int8, &mut buf);
    let good = buf;
    // Any flipped payload bit is caught by the CRC.
    for at in [HEADER_LEN, HEADER_LEN + 7, n - 5] {
        let mut b = good;
        b[at] ^= 0x01;
        assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::Crc), "byte {at}");
    }
    let mut b = good;
    b[0] = b'X';
    assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::BadMagic));
    let mut b = good;
    b[4] = 9;
    assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::Version { found: 9 }));
    let mut b = good;
    b[6] = 7;
    assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::Precision { found: 7 }));
    let mut b = good;
    b[8] = 200; // enc = 200 > MAX_ENC
    assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::UnsupportedDims));
    let mut b = good;
    b[20] = 31; // horizon 31
    assert_eq!(ModelBlob::parse(&b[..n]), Err(BlobError::ShapeMismatch));
    let mut b = good;
    b[8] = 5; // enc = 5: a supported width, but the payload no longer fits it
    assert!(matches!(ModelBlob::parse(&b[..n]), Err(BlobError::Length { .. })));
    assert!(matches!(ModelBlob::parse(&good[..n - 1]), Err(BlobError::TooShort { .. })));
    assert!(matches!(ModelBlob::parse(&[]), Err(BlobError::TooShort { .. })));
    // Trailing bytes (a larger receive buffer) are fine.
    assert!(ModelBlob::parse(&good[..n + 10]).is_ok());
}

#[test]
fn writer_refuses_bad_tensors() {
    let mut buf = [0u8; 8192];
    let too_few: [&[f32]; 1] = [&[0.0; 3]];
    assert_eq!(
        write_blob(&SMALL, Precision::F32, 0.05, &PriorSettings::DEFAULT, &too_few, &mut buf),
        Err(BlobError::TensorShape { index: 0 })
    );
    let mut small = [0u8; 16];
    assert_eq!(
        write_blob(&SMALL, Precision::F32, 0.05, &PriorSettings::DEFAULT, &too_few, &mut small),
        Err(BlobError::BufferTooSmall)
    );
}
