//! The transformation prediction network (the source paper's Fig. 10, its TP module): three
//! 3 x 3 convolutions of stride 2 with ReLU, a dense layer of 32 ReLU units and a dense layer
//! of the warp's 6 numbers. Plain `f32` loops in one fixed order and no libm call, as the other
//! stages are written for the firmware to give the host's bits; the weights are read in place
//! ([`TetrisWeights`]).
//!
//! The input is `[channel][row][column]`: channel 0 the chip, channel 1 the prior, rows across
//! the prior's axis, columns along it ([`super::input`]). The flattening before the dense
//! layers is channel-major, as the trainer's (`[channel][row][column]`).

use super::weights::TetrisWeights;

/// The layer sizes, as the weights file's header states them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Architecture {
    /// Input channels.
    pub channels: usize,
    /// Input rows (across the prior's axis).
    pub rows: usize,
    /// Input columns (along it).
    pub columns: usize,
    /// Output channels of the three convolutions.
    pub convolutions: [usize; 3],
    /// Units of the hidden dense layer.
    pub hidden: usize,
    /// Outputs: the warp's parameters.
    pub outputs: usize,
}

/// The compiled network.
pub const ARCHITECTURE: Architecture = Architecture {
    channels: 2,
    rows: INPUT_ROWS,
    columns: INPUT_COLUMNS,
    convolutions: [8, 16, 32],
    hidden: 32,
    outputs: OUTPUTS,
};

/// Input rows, across the prior's axis.
pub const INPUT_ROWS: usize = 32;
/// Input columns, along the prior's axis.
pub const INPUT_COLUMNS: usize = 64;
/// Samples of the input (both channels).
pub const INPUT_LEN: usize = 2 * INPUT_ROWS * INPUT_COLUMNS;
/// The warp's parameters ([`super::Warp`]).
pub const OUTPUTS: usize = 6;

/// A convolution's shape: `inputs` channels of `rows` x `columns` to `outputs` channels of half
/// the rows and columns.
#[derive(Debug, Clone, Copy)]
struct Convolution {
    inputs: usize,
    outputs: usize,
    rows: usize,
    columns: usize,
}

impl Convolution {
    const fn weights(&self) -> usize {
        self.outputs * self.inputs * 9
    }
    const fn parameters(&self) -> usize {
        self.weights() + self.outputs
    }
    const fn output_len(&self) -> usize {
        self.outputs * (self.rows / 2) * (self.columns / 2)
    }
    const fn next(&self, outputs: usize) -> Convolution {
        Convolution {
            inputs: self.outputs,
            outputs,
            rows: self.rows / 2,
            columns: self.columns / 2,
        }
    }
    /// Multiply-adds of one pass.
    const fn macs(&self) -> usize {
        self.output_len() * self.inputs * 9
    }
}

const CONV1: Convolution = Convolution {
    inputs: 2,
    outputs: ARCHITECTURE.convolutions[0],
    rows: INPUT_ROWS,
    columns: INPUT_COLUMNS,
};
const CONV2: Convolution = CONV1.next(ARCHITECTURE.convolutions[1]);
const CONV3: Convolution = CONV2.next(ARCHITECTURE.convolutions[2]);
/// Inputs of the hidden dense layer: the last convolution's output, flattened.
const FLAT: usize = CONV3.output_len();
const HIDDEN: usize = ARCHITECTURE.hidden;

const CONV1_AT: usize = 0;
const CONV2_AT: usize = CONV1_AT + CONV1.parameters();
const CONV3_AT: usize = CONV2_AT + CONV2.parameters();
const DENSE1_AT: usize = CONV3_AT + CONV3.parameters();
const DENSE2_AT: usize = DENSE1_AT + HIDDEN * FLAT + HIDDEN;

/// Parameters of the network.
pub const PARAMETERS: usize = DENSE2_AT + OUTPUTS * HIDDEN + OUTPUTS;
/// Multiply-adds of one pass.
pub const MULTIPLY_ADDS: usize =
    CONV1.macs() + CONV2.macs() + CONV3.macs() + HIDDEN * FLAT + OUTPUTS * HIDDEN;
/// The network's input and scratch (40 KiB): the first convolution writes `first`, the second
/// `second`, the third `first` again.
#[derive(Debug, Clone)]
pub struct Network {
    input: [f32; INPUT_LEN],
    first: [f32; CONV1.output_len()],
    second: [f32; CONV2.output_len()],
}

impl Default for Network {
    fn default() -> Self {
        Self::new()
    }
}

impl Network {
    /// Zeroed buffers.
    pub const fn new() -> Self {
        Network {
            input: [0.0; INPUT_LEN],
            first: [0.0; CONV1.output_len()],
            second: [0.0; CONV2.output_len()],
        }
    }

    /// The input to fill before [`Network::run`]: `[channel][row][column]`.
    pub fn input_mut(&mut self) -> &mut [f32; INPUT_LEN] {
        &mut self.input
    }

    /// The input as filled.
    pub fn input(&self) -> &[f32; INPUT_LEN] {
        &self.input
    }

    /// The network's outputs for the input in [`Network::input_mut`].
    pub fn run(&mut self, weights: &TetrisWeights) -> [f32; OUTPUTS] {
        convolve(weights, CONV1, CONV1_AT, &self.input, &mut self.first);
        convolve(weights, CONV2, CONV2_AT, &self.first, &mut self.second);
        // FLAT < CONV1.output_len(): the third convolution's output fits the first's buffer.
        let flat = self.first.get_mut(..FLAT).unwrap_or_default();
        convolve(weights, CONV3, CONV3_AT, &self.second, flat);
        let mut hidden = [0.0f32; HIDDEN];
        dense(weights, DENSE1_AT, flat, &mut hidden);
        hidden.iter_mut().for_each(|h| *h = h.max(0.0));
        let mut out = [0.0f32; OUTPUTS];
        dense(weights, DENSE2_AT, &hidden, &mut out);
        out
    }
}

/// A 3 x 3 convolution of stride 2 and zero padding 1, then ReLU: `input` `[in][row][column]`,
/// `output` `[out][row / 2][column / 2]`; the weights at `at` are `[out][in][3][3]`, the biases
/// after them.
fn convolve(weights: &TetrisWeights, c: Convolution, at: usize, input: &[f32], output: &mut [f32]) {
    let (rows, columns) = (c.rows / 2, c.columns / 2);
    let planes = input.chunks_exact(c.rows * c.columns).take(c.inputs);
    let out_planes = output.chunks_exact_mut(rows * columns).take(c.outputs);
    for (o, out_plane) in out_planes.enumerate() {
        let bias = weights.parameter(at + c.weights() + o);
        for (k, out) in out_plane.iter_mut().enumerate() {
            let (y, x) = (k / columns, k % columns);
            let mut sum = 0.0f32;
            for (i, plane) in planes.clone().enumerate() {
                let kernel = at + (o * c.inputs + i) * 9;
                for ky in 0..3 {
                    let Some(sy) = (2 * y + ky).checked_sub(1).filter(|&s| s < c.rows) else {
                        continue;
                    };
                    for kx in 0..3 {
                        let sample = (2 * x + kx)
                            .checked_sub(1)
                            .filter(|&s| s < c.columns)
                            .and_then(|sx| plane.get(sy * c.columns + sx));
                        if let Some(value) = sample {
                            sum += weights.parameter(kernel + 3 * ky + kx) * value;
                        }
                    }
                }
            }
            *out = (sum + bias).max(0.0);
        }
    }
}

/// A dense layer: `output[o] = bias[o] + sum_i w[o][i] input[i]`, the weights at `at`
/// `[out][in]`, the biases after them.
fn dense(weights: &TetrisWeights, at: usize, input: &[f32], output: &mut [f32]) {
    let (n, outputs) = (input.len(), output.len());
    for (o, out) in output.iter_mut().enumerate() {
        let row = at + o * n;
        let mut sum = 0.0f32;
        for (i, x) in input.iter().enumerate() {
            sum += weights.parameter(row + i) * x;
        }
        *out = sum + weights.parameter(at + outputs * n + o);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape_guided::tetris::weights::{FILE_LEN, write};

    /// The layer sizes the docs state.
    #[test]
    fn sizes_are_the_documented_ones() {
        assert_eq!(PARAMETERS, 38_958);
        assert_eq!(MULTIPLY_ADDS, 401_600);
    }

    /// Each convolution passes its input's channel 0 through the kernel's centre, so the third
    /// one's sample (row y, column x) is the input's at (8 y, 8 x); the hidden unit 0 takes the
    /// one at (1, 2), and output 0 is that unit, output 1 its bias -2.
    #[test]
    fn a_hand_wired_network_passes_one_sample() {
        let mut p = [0.0f32; PARAMETERS];
        for at in [CONV1_AT, CONV2_AT, CONV3_AT] {
            p[at + 4] = 1.0; // output 0, input 0, kernel centre
        }
        p[DENSE1_AT + (8 + 2)] = 1.0; // unit 0 reads channel 0, row 1, column 2
        p[DENSE2_AT] = 1.0; // output 0 reads unit 0
        p[DENSE2_AT + OUTPUTS * HIDDEN + 1] = -2.0; // output 1's bias
        let mut bytes = [0u8; FILE_LEN];
        write(&p, 1.5, 4.0, 0, &mut bytes).unwrap();
        let weights = TetrisWeights::new_checked(&bytes).unwrap();
        let mut network = Network::new();
        network.input_mut()[8 * INPUT_COLUMNS + 16] = 0.75;
        network.input_mut()[8 * INPUT_COLUMNS + 17] = 9.0; // not on the stride's grid
        let out = network.run(&weights);
        assert_eq!(out, [0.75, -2.0, 0.0, 0.0, 0.0, 0.0]);
        // A negative sample is cut by the first ReLU.
        network.input_mut()[8 * INPUT_COLUMNS + 16] = -0.75;
        assert_eq!(network.run(&weights)[0], 0.0);
    }
}
