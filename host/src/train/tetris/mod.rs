//! `imade train tetris`: trains the core's TETRIS network on the CPU with candle and writes its
//! weights (`imade-tetris/1`), the loss curve (CSV and PNG) beside them, and a validation on
//! chips of clips it did not train on, scored by the core's own inference.
//!
//! Deterministic for a seed on a given machine: every chip, prior and initial weight comes from
//! a stream keyed by the seed ([`Random`]); candle's CPU kernels sum in a fixed order for a given
//! thread count.

pub mod data;
pub mod net;

use crate::clip::write_atomically;
use crate::sim::random::{Purpose, Random};
use anyhow::Context;
use candle_core::{Device, Tensor};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use data::{CROP_LENGTHS, CROP_WIDTHS, Perturbation, Sample, TrainingChip};
use imade_core::mask::ChipMask;
use imade_core::shape_guided::tetris::network::{INPUT_COLUMNS, INPUT_LEN, INPUT_ROWS};
use imade_core::shape_guided::tetris::weights::{self, FILE_LEN, TetrisWeights};
use imade_core::shape_guided::tetris::{Tetris, TetrisConfig, input::PLANE};
use imade_core::shape_guided::{PriorShape, warp::warp_prior};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `imade train tetris`.
#[derive(Debug, Clone, clap::Args)]
pub struct TetrisArgs {
    /// The weights file to write (imade-tetris/1); the loss curve goes beside it
    /// (`FILE.loss.csv`, `FILE.loss.png`).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of every draw: the clips' scenes, the frames, the priors' perturbations, the initial
    /// weights.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Optimizer steps.
    #[arg(long, default_value_t = 8000)]
    pub steps: usize,
    /// Samples a step.
    #[arg(long, default_value_t = 32)]
    pub batch: usize,
    /// Simulated clips to train on (the presets in turn).
    #[arg(long, default_value_t = 84)]
    pub clips: usize,
    /// Chips rendered from each clip.
    #[arg(long, default_value_t = 10)]
    pub frames_per_clip: usize,
    /// Further clips, of other seeds, to validate on.
    #[arg(long, default_value_t = 7)]
    pub validation_clips: usize,
    /// AdamW's learning rate; a tenth of it over the last third of the steps.
    #[arg(long, default_value_t = 2e-3)]
    pub learning_rate: f64,
}

/// What a training run gave.
#[derive(Debug, Clone)]
pub struct TrainingReport {
    /// The loss of every step.
    pub losses: Vec<f64>,
    /// Median IoU of the perturbed priors with the true masks on the validation chips ...
    pub prior_iou: f64,
    /// ... and of the priors TETRIS warped (the core's inference, chip px).
    pub warped_iou: f64,
    /// Validation samples.
    pub validated: usize,
    /// Training chips.
    pub chips: usize,
    /// Wall time, s.
    pub seconds: f64,
}

impl TrainingReport {
    /// The mean loss over the first or last `n` steps.
    pub fn mean_loss(&self, first: bool, n: usize) -> f64 {
        let n = n.min(self.losses.len()).max(1);
        let part = if first {
            &self.losses[..n]
        } else {
            &self.losses[self.losses.len() - n..]
        };
        part.iter().sum::<f64>() / n as f64
    }
}

/// Index offsets keeping the streams of the training samples, the validation draws and the
/// initial weights apart.
const VALIDATION_STREAM: u64 = 1 << 40;
const WEIGHTS_STREAM: u64 = 1 << 41;

/// Runs `imade train tetris`.
pub fn run(args: &TetrisArgs) -> anyhow::Result<TrainingReport> {
    anyhow::ensure!(
        args.steps > 0 && args.batch > 0 && args.clips > 0,
        "nothing to train"
    );
    // Refused before the minutes of training, not after.
    let folder = match args.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    anyhow::ensure!(
        folder.is_dir() && !args.out.is_dir(),
        "cannot write the weights to {}: its folder must exist and it must not be a folder",
        args.out.display()
    );
    let started = Instant::now();
    let chips = data::render_chips(args.seed, 0..args.clips, args.frames_per_clip)?;
    let validation = data::render_chips(
        args.seed,
        args.clips..args.clips + args.validation_clips,
        args.frames_per_clip.min(4),
    )?;
    eprintln!(
        "imade train tetris: {} training chips, {} validation chips rendered in {:.1} s",
        chips.len(),
        validation.len(),
        started.elapsed().as_secs_f64()
    );
    let network = net::Network::new(&mut Random::new(
        args.seed,
        Purpose::Training,
        WEIGHTS_STREAM,
    ))?;
    let losses = train(&network, &chips, args)?;
    let parameters = network.parameters()?;
    let mut bytes = vec![0u8; FILE_LEN];
    weights::write(
        &parameters,
        CROP_LENGTHS,
        CROP_WIDTHS,
        args.seed,
        &mut bytes,
    )
    .context("the network's parameters do not fit the weights format")?;
    let weights = TetrisWeights::new_checked(&bytes)
        .map_err(|e| anyhow::anyhow!("the trained weights do not validate: {e:?}"))?;
    let (prior_iou, warped_iou, validated) = validate(&weights, &validation, args.seed);
    write_atomically(&args.out, &bytes)?;
    write_loss_curve(&args.out, &losses)?;
    let report = TrainingReport {
        losses,
        prior_iou,
        warped_iou,
        validated,
        chips: chips.len(),
        seconds: started.elapsed().as_secs_f64(),
    };
    let window = (args.steps / 4).clamp(1, 100);
    eprintln!(
        "imade train tetris: loss {:.4} -> {:.4} (first and last {window} steps); validation \
         median IoU {:.3} (perturbed prior) -> {:.3} (warped), {} samples; {:.0} s; wrote {}",
        report.mean_loss(true, window),
        report.mean_loss(false, window),
        prior_iou,
        warped_iou,
        validated,
        report.seconds,
        args.out.display()
    );
    Ok(report)
}

/// Trains `network` in place; returns the loss of every step.
fn train(
    network: &net::Network,
    chips: &[TrainingChip],
    args: &TetrisArgs,
) -> anyhow::Result<Vec<f64>> {
    let grid = net::Grid::new()?;
    let params = ParamsAdamW {
        lr: args.learning_rate,
        weight_decay: 1e-4,
        ..ParamsAdamW::default()
    };
    let mut optimizer = AdamW::new(network.vars(), params)?;
    let bar = progress_bar(args.steps);
    let mut losses = Vec::with_capacity(args.steps);
    for step in 0..args.steps {
        if step == 2 * args.steps / 3 {
            optimizer.set_learning_rate(0.1 * args.learning_rate);
        }
        let first = (step * args.batch) as u64;
        let samples = draw_batch(chips, args.seed, first, args.batch);
        let (input, target) = batch_tensors(&samples)?;
        let prior = input.narrow(1, 1, 1)?.reshape((samples.len(), PLANE))?;
        let warp = network.forward(&input)?;
        let loss = net::loss(&grid.warp(&prior, &warp)?, &target)?;
        optimizer.backward_step(&loss)?;
        let value = f64::from(loss.to_scalar::<f32>()?);
        losses.push(value);
        bar.set_message(format!("loss {value:.4}"));
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(losses)
}

/// The samples `first..first + n` of the training stream: each a chip and a perturbed prior of
/// its own draw (an unusable draw is drawn again, at most 8 times).
fn draw_batch(chips: &[TrainingChip], seed: u64, first: u64, n: usize) -> Vec<Sample> {
    (0..n as u64)
        .into_par_iter()
        .filter_map(|k| {
            let mut random = Random::new(seed, Purpose::Training, first + k);
            (0..8).find_map(|_| {
                chips
                    .get(random.index(chips.len()))?
                    .sample(&Perturbation::DEFAULT, &mut random)
            })
        })
        .collect()
}

/// The batch as tensors: inputs `(B, 2, rows, columns)` and targets `(B, PLANE)`.
fn batch_tensors(samples: &[Sample]) -> anyhow::Result<(Tensor, Tensor)> {
    let n = samples.len();
    anyhow::ensure!(n > 0, "no usable training sample was drawn");
    let input: Vec<f32> = samples
        .iter()
        .flat_map(|s| s.input.iter().copied())
        .collect();
    let target: Vec<f32> = samples
        .iter()
        .flat_map(|s| s.target.iter().copied())
        .collect();
    debug_assert_eq!(input.len(), n * INPUT_LEN);
    Ok((
        Tensor::from_vec(input, (n, 2, INPUT_ROWS, INPUT_COLUMNS), &Device::Cpu)?,
        Tensor::from_vec(target, (n, PLANE), &Device::Cpu)?,
    ))
}

/// Priors drawn for each validation chip.
const PRIORS_PER_VALIDATION_CHIP: usize = 3;

/// The median IoU with the true mask, in chip px, of perturbed priors of each validation chip
/// (three a chip) and of those priors warped by the core's TETRIS with
/// `weights`; and the samples scored.
pub fn validate(weights: &TetrisWeights, chips: &[TrainingChip], seed: u64) -> (f64, f64, usize) {
    let draws = chips.len() * PRIORS_PER_VALIDATION_CHIP;
    let scores: Vec<(f64, f64)> = (0..draws)
        .into_par_iter()
        .filter_map(|i| {
            let chip = &chips[i / PRIORS_PER_VALIDATION_CHIP];
            let mut random = Random::new(seed, Purpose::Training, VALIDATION_STREAM + i as u64);
            let prior = chip.prior(&Perturbation::DEFAULT, &mut random)?;
            let shape = PriorShape::measure(&prior)?;
            let view = chip.view()?;
            let mut tetris = Box::new(Tetris::new());
            let result = tetris
                .run(&view, &prior, &shape, weights, &TetrisConfig::DEFAULT)
                .ok()?;
            let mut warped = Box::new(ChipMask::new());
            warp_prior(&prior, &shape, &result.transform, &mut warped).ok()?;
            Some((
                mask_iou(&prior, &chip.truth),
                mask_iou(&warped, &chip.truth),
            ))
        })
        .collect();
    let median = |f: fn(&(f64, f64)) -> f64| {
        let mut v: Vec<f64> = scores.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    (median(|s| s.0), median(|s| s.1), scores.len())
}

/// Intersection over union of two masks of the same size.
fn mask_iou(a: &ChipMask, b: &ChipMask) -> f64 {
    let (w, h) = (a.width(), a.height());
    let bits = |m: &ChipMask| -> Vec<bool> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| m.get(x, y))
            .collect()
    };
    crate::eval::iou::iou(&bits(a), &bits(b))
}

fn progress_bar(steps: usize) -> ProgressBar {
    let bar = ProgressBar::new(steps as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed:>4} [{bar:40}] {pos}/{len} steps, {msg}, eta {eta}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// `FILE.loss.csv` (step, loss) and `FILE.loss.png` beside the weights `out`.
fn write_loss_curve(out: &Path, losses: &[f64]) -> anyhow::Result<()> {
    let beside = |suffix: &str| {
        let mut name = out.file_name().unwrap_or_default().to_os_string();
        name.push(suffix);
        out.with_file_name(name)
    };
    let mut csv = String::from("step,loss\n");
    for (step, loss) in losses.iter().enumerate() {
        csv.push_str(&format!("{step},{loss}\n"));
    }
    write_atomically(&beside(".loss.csv"), csv.as_bytes())?;
    crate::plot::loss::plot(losses, &beside(".loss.png"))
}
