//! TETRIS's weights parser and inference: `TetrisWeights::new_checked` on raw bytes, and on the
//! bundled weights with fuzzer-chosen bytes written over them and the checksum made right again
//! (any finite weights then pass validation); weights that validate warp a fuzzer-chosen prior
//! on a fuzzer-chosen chip. A result is a finite transform or an error, never a panic.
#![no_main]

use arbitrary::Arbitrary;
use imade_core::ChipView;
use imade_core::mask::ChipMask;
use imade_core::shape_guided::tetris::weights::FILE_LEN;
use imade_core::shape_guided::{PriorShape, Tetris, TetrisConfig, TetrisWeights};
use imade_core_fuzz::TETRIS_BYTES;
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
enum Weights {
    /// Bytes parsed as they are.
    Raw(Vec<u8>),
    /// The bundled weights with `bytes` written at `at`, the checksum right.
    Patched { at: u32, bytes: Vec<u8> },
}

#[derive(Arbitrary, Debug)]
struct Input {
    weights: Weights,
    /// Chip width and height, 1 to 64 px.
    size: (u8, u8),
    /// The chip's samples, repeated.
    samples: Vec<u8>,
    /// The prior's box: first and last column and row (wrapped into the chip).
    prior: [u8; 4],
    /// Passes of the network.
    passes: u8,
}

fuzz_target!(|input: Input| {
    let bytes = match &input.weights {
        Weights::Raw(bytes) => bytes.clone(),
        Weights::Patched { at, bytes } => {
            let mut file = TETRIS_BYTES.to_vec();
            let start = (*at as usize) % FILE_LEN;
            for (slot, b) in file[start..].iter_mut().zip(bytes) {
                *slot = *b;
            }
            let crc = imade_core::bytes::CRC.checksum(&file[..FILE_LEN - 4]);
            file[FILE_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
            file
        }
    };
    let Ok(weights) = TetrisWeights::new_checked(&bytes) else {
        return;
    };
    let (w, h) = (
        usize::from(input.size.0 % 64) + 1,
        usize::from(input.size.1 % 64) + 1,
    );
    let data: Vec<u8> = if input.samples.is_empty() {
        vec![0; w * h]
    } else {
        input.samples.iter().copied().cycle().take(w * h).collect()
    };
    let chip = ChipView::gray8(&data, w, h, w, 0, 0).expect("a valid chip");
    let mut prior = Box::new(ChipMask::new());
    prior.reset(w, h).expect("a small mask");
    let [x0, x1, y0, y1] = input.prior.map(usize::from);
    for y in (y0.min(y1) % h)..=(y0.max(y1) % h).max(y0.min(y1) % h) {
        prior.set_run(y, x0.min(x1) % w, (x0.max(x1) % w).max(x0.min(x1) % w));
    }
    let Some(shape) = PriorShape::measure(&prior) else {
        return;
    };
    let mut tetris = Box::new(Tetris::new());
    let config = TetrisConfig {
        passes: input.passes,
    };
    if let Ok(result) = tetris.run(&chip, &prior, &shape, &weights, &config) {
        assert!(result.transform.is_finite(), "{result:?}");
    }
});
