//! The int8 products on the MCU: SMLAD ([`DspDot`]) against the portable code ([`PortableDot`]),
//! bit for bit, then inference timed in instructions per forecast (f32, int8 portable, int8 on
//! SMLAD) for blobs of seeded random weights (a trained model of the same widths does the same
//! arithmetic). Exit status 0 when every product and forecast agrees, 1 otherwise. Run by
//! tests/tests/kernels_qemu.rs (`bash scripts/qemu-edge.sh --port none --elf ...`).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use dynotraj_core::geometry::{BevState, Point2};
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::blob::{ModelBlob, Precision, blob_len};
use dynotraj_core::model::kernel::MAX_AFFINE_IN;
use dynotraj_core::model::stand_in::{STAND_IN_SEED, write_stand_in_blob};
use dynotraj_core::model::{Dims, Int8Dot, LearnedPredictor, PortableDot};
use dynotraj_core::predict::{Context, Dynamics, Predictor as _};
use dynotraj_dsp::DspDot;
use dynotraj_firmware::clock;
use dynotraj_firmware::exit::{fail, fail_with, succeed};

// The device interrupt vectors: none is used.
dynotraj_firmware::device_interrupts!();

/// The widths timed: the ECU default, its one-mode variant, and the 16-wide network of the size
/// study. Wider ones do not fit their f32 blob in the board's 128 KiB of RAM.
const TIMED: [Dims; 3] =
    [Dims::DEFAULT, Dims { enc: 8, edge: 8, k: 1, dec: 8 }, Dims { enc: 16, edge: 16, k: 1, dec: 16 }];
/// The largest of [`TIMED`], which sizes the buffers.
const LARGEST: Dims = Dims { enc: 16, edge: 16, k: 1, dec: 16 };
/// Frame period of the blobs, s.
const DT: f32 = 0.1;
/// Forecasts per timing (the cost is the same every time; the first fills the caches of nothing,
/// there are none, but is not counted either).
const REPEATS: u64 = 3;

#[entry]
fn main() -> ! {
    let _peripherals = dynotraj_firmware::session::start();
    hprintln!("dynotraj-kernels: int8 products {}", if dynotraj_dsp::SMLAD { "on SMLAD" } else { "portable" });

    let (cases, differ) = check_products();
    hprintln!("dynotraj-kernels: products: {} cases, {} differ (SMLAD against portable)", cases, differ);

    let mut tensors = [0.0f32; LARGEST.parameters()];
    let mut f32_blob = [0u8; blob_len(&LARGEST, Precision::F32)];
    let mut int8_blob = [0u8; blob_len(&LARGEST, Precision::Int8)];
    let mut forecasts_differ = 0;
    for dims in TIMED {
        let (Ok(f), Ok(q)) = (
            random_blob(&dims, Precision::F32, &mut tensors, &mut f32_blob),
            random_blob(&dims, Precision::Int8, &mut tensors, &mut int8_blob),
        ) else {
            fail_with(format_args!("{dims:?}: no blob"))
        };
        let f32_cost = forecast_cost(LearnedPredictor::<PortableDot>::with_dot(f)).0;
        let (portable_cost, portable) = forecast_cost(LearnedPredictor::<PortableDot>::with_dot(q));
        let (smlad_cost, smlad) = forecast_cost(LearnedPredictor::<DspDot>::with_dot(q));
        let same = portable.iter().zip(&smlad).all(|(a, b)| bits(a) == bits(b));
        forecasts_differ += usize::from(!same);
        hprintln!(
            "dynotraj-kernels: forecast {},{},{},{}: f32 {} | int8 portable {} | int8 SMLAD {} instructions; int8 \
                SMLAD {}.{:02}x faster than f32, {}.{:02}x than portable; forecasts {}",
            dims.enc,
            dims.edge,
            dims.k,
            dims.dec,
            f32_cost,
            portable_cost,
            smlad_cost,
            ratio_100(f32_cost, smlad_cost) / 100,
            ratio_100(f32_cost, smlad_cost) % 100,
            ratio_100(portable_cost, smlad_cost) / 100,
            ratio_100(portable_cost, smlad_cost) % 100,
            if same { "equal bit for bit" } else { "DIFFER" }
        );
    }
    if differ > 0 || forecasts_differ > 0 {
        fail_with(format_args!("{differ} products and {forecasts_differ} forecasts differ"));
    }
    succeed()
}

/// `100 * a / b`, rounded down.
fn ratio_100(a: u64, b: u64) -> u64 {
    (100 * a).checked_div(b).unwrap_or(0)
}

fn bits(p: &Point2) -> (u32, u32) {
    (p.x.to_bits(), p.y.to_bits())
}

/// Rows of weights in [`check_products`]' matrix, at most.
const CHECK_ROWS: usize = 9;
/// Its longest row: an input of the longest length, and up to two columns skipped.
const CHECK_STRIDE: usize = MAX_AFFINE_IN + 2;

/// SMLAD against portable for every input length up to [`MAX_AFFINE_IN`], with 1 to
/// [`CHECK_ROWS`] rows (whole blocks of four and remainders), a row stride that differs from the
/// length and a first column other than 0; each with seeded random bytes, with every byte -128
/// (the largest products) and with bytes alternating 127 and -128. Returns (cases, cases that
/// differ).
fn check_products() -> (usize, usize) {
    let mut rng = Lcg(0x1234_5678);
    let (mut cases, mut differ) = (0, 0);
    let mut w = [0u8; CHECK_ROWS * CHECK_STRIDE];
    let mut x = [0i8; MAX_AFFINE_IN];
    for len in 0..=MAX_AFFINE_IN {
        let (skip, rows) = (len % 3, 1 + len % CHECK_ROWS);
        let stride = len + skip;
        for pattern in 0..3 {
            for (i, xi) in x.iter_mut().enumerate() {
                *xi = match pattern {
                    0 => rng.byte() as i8,
                    1 => i8::MIN,
                    _ => [i8::MAX, i8::MIN][i % 2],
                };
            }
            for (i, wi) in w.iter_mut().enumerate() {
                *wi = match pattern {
                    0 => rng.byte(),
                    1 => 0x80,
                    _ => [0x80, 0x7f][i % 2],
                };
            }
            let (Some(ws), Some(xs)) = (w.get(skip..), x.get(..len)) else { continue };
            let (mut smlad, mut portable) = ([0i32; CHECK_ROWS], [1i32; CHECK_ROWS]);
            let (Some(a), Some(b)) = (smlad.get_mut(..rows), portable.get_mut(..rows)) else { continue };
            DspDot::rows(ws, stride, xs, a);
            PortableDot::rows(ws, stride, xs, b);
            cases += 1;
            differ += usize::from(a != b);
        }
    }
    (cases, differ)
}

/// Instructions per forecast of `p` on a fixed history with one neighbour, and the forecast.
fn forecast_cost<D: Int8Dot>(mut p: LearnedPredictor<'_, D>) -> (u64, [Point2; HORIZON]) {
    let history: [BevState; 7] = core::array::from_fn(|i| {
        let t = i as f32;
        BevState { x: 0.5 * t, y: 0.02 * t * t, heading: 0.05 * t, speed: 10.0 }
    });
    let other: [BevState; 7] =
        core::array::from_fn(|i| BevState { x: 0.4 * i as f32, y: 4.0, heading: 0.0, speed: 8.0 });
    let neighbours: [&[BevState]; 1] = [&other];
    let mut out = [Point2::default(); HORIZON];
    if p.predict_in_context(&history, &Context::with_neighbours(&neighbours), DT, &mut out).is_err() {
        fail("a random-weight forecast was refused");
    }
    let start = clock::ticks();
    for _ in 0..REPEATS {
        let _ = p.predict_in_context(&history, &Context::with_neighbours(&neighbours), DT, &mut out);
    }
    ((clock::ticks() - start) * clock::INSTRUCTIONS_PER_TICK / REPEATS, out)
}

/// A blob of `dims` with the stand-in weights in `out`, its f32 weights written to `tensors`
/// first (the same seed for both precisions: the int8 blob is the f32 one quantised).
fn random_blob<'a>(
    dims: &Dims,
    precision: Precision,
    tensors: &mut [f32],
    out: &'a mut [u8],
) -> Result<ModelBlob<'a>, ()> {
    let stand_in = (dims, precision, Dynamics::Unicycle);
    let len = write_stand_in_blob(stand_in, DT, STAND_IN_SEED, tensors, out).map_err(|_| ())?;
    ModelBlob::parse(out.get(..len).ok_or(())?).map_err(|_| ())
}

/// A linear congruential generator (Numerical Recipes' constants): test data, not randomness.
struct Lcg(u32);

impl Lcg {
    fn byte(&mut self) -> u8 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (self.0 >> 24) as u8
    }
}
