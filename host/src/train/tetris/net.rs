//! The network of the core's TETRIS (`imade_core::shape_guided::tetris::network`) in candle, for
//! training: the same layers and parameter order, and the spatial transformer's warp of the
//! prior with the L2 loss against the true mask (the source paper's Section 4.3.3).

use crate::sim::random::Random;
use candle_core::{D, DType, Device, Tensor, Var};
use imade_core::shape_guided::tetris::input::{PLANE, sample_point};
use imade_core::shape_guided::tetris::network::{ARCHITECTURE, INPUT_COLUMNS, INPUT_ROWS, OUTPUTS};

/// One layer's trainable weight and bias.
struct Layer {
    weight: Var,
    bias: Var,
}

impl Layer {
    /// Kaiming-uniform weights of `shape` (`fan_in` inputs a unit) and zero biases, drawn from
    /// `random`; `scale` 0 makes the layer start at zero.
    fn new(
        shape: &[usize],
        fan_in: usize,
        scale: f64,
        random: &mut Random,
    ) -> candle_core::Result<Layer> {
        let n: usize = shape.iter().product();
        let bound = scale * (6.0 / fan_in as f64).sqrt();
        let values: Vec<f32> = (0..n)
            .map(|_| random.between(-bound, bound) as f32)
            .collect();
        Ok(Layer {
            weight: Var::from_tensor(&Tensor::from_vec(values, shape, &Device::Cpu)?)?,
            bias: Var::zeros(shape[0], DType::F32, &Device::Cpu)?,
        })
    }
}

/// The trainable network.
pub struct Network {
    convolutions: [Layer; 3],
    hidden: Layer,
    output: Layer,
}

impl Network {
    /// Fresh weights from `random`; the output layer starts at zero, so the first warp is the
    /// identity (the prior as given).
    pub fn new(random: &mut Random) -> candle_core::Result<Network> {
        let [c1, c2, c3] = ARCHITECTURE.convolutions;
        let conv = |out: usize, inp: usize, random: &mut Random| {
            Layer::new(&[out, inp, 3, 3], inp * 9, 1.0, random)
        };
        let flat = c3 * (INPUT_ROWS / 8) * (INPUT_COLUMNS / 8);
        Ok(Network {
            convolutions: [
                conv(c1, ARCHITECTURE.channels, random)?,
                conv(c2, c1, random)?,
                conv(c3, c2, random)?,
            ],
            hidden: Layer::new(&[ARCHITECTURE.hidden, flat], flat, 1.0, random)?,
            output: Layer::new(
                &[OUTPUTS, ARCHITECTURE.hidden],
                ARCHITECTURE.hidden,
                0.0,
                random,
            )?,
        })
    }

    /// The trainable variables.
    pub fn vars(&self) -> Vec<Var> {
        self.layers()
            .flat_map(|l| [l.weight.clone(), l.bias.clone()])
            .collect()
    }

    fn layers(&self) -> impl Iterator<Item = &Layer> {
        self.convolutions.iter().chain([&self.hidden, &self.output])
    }

    /// The parameters in the core's file order: each layer's weights, then its biases.
    pub fn parameters(&self) -> candle_core::Result<Vec<f32>> {
        let mut out = Vec::new();
        for v in self.vars() {
            out.extend(v.as_tensor().flatten_all()?.to_vec1::<f32>()?);
        }
        Ok(out)
    }

    /// The warp's 6 numbers for a batch of inputs `(B, 2, rows, columns)`: `(B, 6)`.
    pub fn forward(&self, input: &Tensor) -> candle_core::Result<Tensor> {
        let mut x = input.clone();
        for layer in &self.convolutions {
            let bias = layer.bias.as_tensor().reshape((1, (), 1, 1))?;
            x = x
                .conv2d(layer.weight.as_tensor(), 1, 2, 1, 1)?
                .broadcast_add(&bias)?
                .relu()?;
        }
        let x = x.flatten_from(1)?;
        let dense = |x: &Tensor, l: &Layer| {
            x.matmul(&l.weight.as_tensor().t()?)?
                .broadcast_add(l.bias.as_tensor())
        };
        dense(&dense(&x, &self.hidden)?.relu()?, &self.output)
    }
}

/// The crop's sample points, `(1, PLANE)` each coordinate.
pub struct Grid {
    s: Tensor,
    t: Tensor,
}

impl Grid {
    /// The points of `sample_point`, as the core samples them.
    pub fn new() -> candle_core::Result<Grid> {
        let points: Vec<_> = (0..PLANE)
            .map(|k| sample_point(k / INPUT_COLUMNS, k % INPUT_COLUMNS))
            .collect();
        let s: Vec<f32> = points.iter().map(|p| p.x).collect();
        let t: Vec<f32> = points.iter().map(|p| p.y).collect();
        Ok(Grid {
            s: Tensor::from_vec(s, (1, PLANE), &Device::Cpu)?,
            t: Tensor::from_vec(t, (1, PLANE), &Device::Cpu)?,
        })
    }

    /// The prior planes `(B, PLANE)` warped by `warp` `(B, 6)`: each sample takes the prior at
    /// `q = (I + [[a, b], [c, d]]) p + (e, f)`, bilinear, 0 off the crop (the warp of the core's
    /// `shape_guided::tetris` module doc). Differentiable in `warp`.
    pub fn warp(&self, prior: &Tensor, warp: &Tensor) -> candle_core::Result<Tensor> {
        let o = |k: usize| warp.narrow(1, k, 1);
        let qs = self
            .s
            .broadcast_mul(&(o(0)? + 1.0)?)?
            .broadcast_add(&self.t.broadcast_mul(&o(1)?)?)?
            .broadcast_add(&o(4)?)?;
        let qt = self
            .s
            .broadcast_mul(&o(2)?)?
            .broadcast_add(&self.t.broadcast_mul(&(o(3)? + 1.0)?)?)?
            .broadcast_add(&o(5)?)?;
        // Sample coordinates: column i at s = (i + 0.5) / (columns / 2) - 1.
        let x = ((qs + 1.0)? * (0.5 * INPUT_COLUMNS as f64))? - 0.5;
        let y = ((qt + 1.0)? * (0.5 * INPUT_ROWS as f64))? - 0.5;
        let (x, y) = (x?, y?);
        let (x0, y0) = (x.detach().floor()?, y.detach().floor()?);
        let (fx, fy) = ((&x - &x0)?, (&y - &y0)?);
        let corner = |dx: f64, dy: f64| -> candle_core::Result<Tensor> {
            let (cx, cy) = ((&x0 + dx)?, (&y0 + dy)?);
            let inside = cx
                .ge(0.0)?
                .mul(&cx.le(INPUT_COLUMNS as f64 - 1.0)?)?
                .mul(&cy.ge(0.0)?)?
                .mul(&cy.le(INPUT_ROWS as f64 - 1.0)?)?
                .to_dtype(DType::F32)?;
            let index = (cy.clamp(0.0, INPUT_ROWS as f64 - 1.0)? * INPUT_COLUMNS as f64)?
                .add(&cx.clamp(0.0, INPUT_COLUMNS as f64 - 1.0)?)?
                .to_dtype(DType::U32)?;
            prior.gather(&index, 1)?.mul(&inside)
        };
        let (one_x, one_y) = ((1.0 - &fx)?, (1.0 - &fy)?);
        let top = (corner(0.0, 0.0)?.mul(&one_x)? + corner(1.0, 0.0)?.mul(&fx)?)?;
        let bottom = (corner(0.0, 1.0)?.mul(&one_x)? + corner(1.0, 1.0)?.mul(&fx)?)?;
        top.mul(&one_y)? + bottom.mul(&fy)?
    }
}

/// The mean squared difference between the warped priors and the true masks, `(B, PLANE)` each.
pub fn loss(warped: &Tensor, target: &Tensor) -> candle_core::Result<Tensor> {
    (warped - target)?.sqr()?.mean(D::Minus1)?.mean_all()
}
