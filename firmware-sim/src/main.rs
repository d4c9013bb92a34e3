//! # imade-firmware
//!
//! imade-core as Cortex-M4F firmware on QEMU's mps2-an386: replays a clip packed by `imade pack`
//! (imade-pack/1) through the same `Pipeline`, with the same temporal state, as `imade run`, and
//! reports every frame through defmt (semihosting stdout, decoded by `defmt-print`) and as an
//! imade-results/1 row.
//!
//! Arguments (QEMU `-semihosting-config arg=firmware,arg=...`): the packed clip, then the files
//! to write: results CSV, outcomes, measurements CSV ([`outputs`]). Exit code 0 on success, 1 on
//! an error, 101 on a panic, 102 on a hard fault.
//! Run it with `firmware-sim/run` (docs/firmware.md).
#![no_std]
#![no_main]
#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

mod host_io;
mod icount;
mod models;
mod outputs;
mod stack;

// The critical-section implementation (single core) that defmt's logger needs.
use cortex_m as _;
// The defmt global logger: frames over semihosting stdout.
use defmt_semihosting as _;

use host_io::{Args, IoError};
use icount::InstructionCounter;
use imade_core::capacity::{DEFAULT_MAX_LABELS, DEFAULT_MAX_RUNS, mask_words};
use imade_core::lut::table::Table;
use imade_core::{
    Config, FrameInput, FrameResult, MatchConfig, ModelError, Pipeline, ProjectileModel,
};
use imade_pack::{ReadError, TableUse};
use outputs::{OutputError, Outputs};
use static_cell::ConstStaticCell;

/// The chip buffer, 16-bit words: 64 KiB, a 256 x 256 8-bit chip (or 256 x 128 16-bit).
const CHIP_WORDS: usize = 32 * 1024;

/// The largest chip side, px: the pipeline's masks are sized for it (8 KiB each).
const CHIP_SIDE: usize = 256;

/// The bar search's grid: none. Its 48 KiB (three 4096-block grids) do not fit beside the
/// pipeline in 192 KiB yet (docs/firmware.md), so detection in clutter is the host's until the
/// stages share their working memory. Where the components find a body of the body's polarity
/// and high contrast, clear of the chip's edge, the host does not search either.
const BAR_CELLS: usize = 0;

/// The core's pipeline with masks for chips up to [`CHIP_SIDE`] (a larger chip is a capacity
/// status), without the bar search ([`BAR_CELLS`]).
type FirmwarePipeline =
    Pipeline<DEFAULT_MAX_RUNS, DEFAULT_MAX_LABELS, { mask_words(CHIP_SIDE) }, BAR_CELLS>;

/// Length of the delay loop that checks the counter at start: `cortex_m::asm::delay(n)` runs
/// n + 1 iterations of `subs` + `bne`.
const CALIBRATION_CYCLES: u32 = 1_000_000;

static CHIP: ConstStaticCell<[u16; CHIP_WORDS]> = ConstStaticCell::new([0; CHIP_WORDS]);

/// Why the firmware stopped.
#[derive(defmt::Format)]
enum Error {
    /// Fewer than four arguments.
    Usage,
    /// A semihosting call failed.
    Io(IoError),
    /// The packed clip could not be read.
    Read(ReadError<IoError>),
    /// The clip's projectile is not one of the bundled models.
    UnknownProjectile,
    /// The clip asks for the bundled table, and its projectile's model file carries none.
    NoBundledTable,
    /// The bundled model file does not validate.
    Model(ModelError),
    /// A frame could not be reported.
    Output(OutputError),
    /// The chip buffer or the core peripherals were taken twice.
    Taken,
}

impl From<IoError> for Error {
    fn from(e: IoError) -> Self {
        Error::Io(e)
    }
}

impl From<OutputError> for Error {
    fn from(e: OutputError) -> Self {
        Error::Output(e)
    }
}

impl From<ReadError<IoError>> for Error {
    fn from(e: ReadError<IoError>) -> Self {
        Error::Read(e)
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let code = match run() {
        Ok(()) => 0,
        Err(e) => {
            defmt::error!("firmware stopped: {}", e);
            1
        }
    };
    semihosting::process::exit(code)
}

fn run() -> Result<(), Error> {
    let args = Args::get()?;
    let mut args = args.iter();
    let (Some(input), Some(results_path), Some(outcomes_path), Some(measurements_path)) =
        (args.next(), args.next(), args.next(), args.next())
    else {
        return Err(Error::Usage);
    };
    let peripherals = cortex_m::Peripherals::take().ok_or(Error::Taken)?;
    let mut counter = InstructionCounter::new(peripherals.SYST);
    let ((), calibration) = counter.measure(|| cortex_m::asm::delay(CALIBRATION_CYCLES));
    defmt::info!(
        "instruction counter check: cortex_m::asm::delay({=u32}) runs {=u32} instructions, counted {}",
        CALIBRATION_CYCLES,
        2 * (CALIBRATION_CYCLES + 1),
        calibration
    );
    let mut input = host_io::open(input)?;
    let header = imade_pack::read_header(&mut input)?;
    defmt::info!(
        "clip: {=u32} frames, projectile {=str}, {}, range {}, table {}; stack region {=usize} B",
        header.records,
        header.projectile.as_str(),
        header.camera,
        header.range_use,
        header.table,
        stack::region_bytes()
    );
    let model = models::bundled(header.projectile.as_str())
        .ok_or(Error::UnknownProjectile)?
        .map_err(Error::Model)?;
    let table = table(header.table, &model)?;
    let chip = CHIP.try_take().ok_or(Error::Taken)?;
    // The pipeline lives in this stack frame, built in place (docs/firmware.md: a static one
    // would be built on the stack and copied, or cost its initial image in flash). It draws no
    // shape prior: the firmware displays nothing, and the results do not depend on it.
    let defaults = header.config();
    let config = Config {
        table_match: MatchConfig {
            shape_prior: false,
            ..defaults.table_match
        },
        ..defaults
    };
    let mut pipeline = FirmwarePipeline::new(config, header.camera, model);
    // In place: moving the pipeline into `with_table` and back cost 80 KB of stack.
    if let Some(table) = table {
        pipeline.set_table(table);
    }
    if let Some(station) = header.world {
        pipeline.set_station(station);
    }
    defmt::info!(
        "pipeline: {=usize} B (on the stack), chip buffer: {=usize} B (static); stack peak so far {=usize} B",
        core::mem::size_of_val(&pipeline),
        core::mem::size_of_val(chip),
        stack::peak_bytes()
    );
    let mut outputs = Outputs::create(
        results_path,
        outcomes_path,
        measurements_path,
        header.world.is_some(),
    )?;
    for _ in 0..header.records {
        let record = imade_pack::read_record(&mut input, chip)?;
        let mut instructions = None;
        let outcome = imade_pack::replay(&record, chip, |frame| {
            let (result, count) = counter.measure(|| process(&mut pipeline, frame));
            instructions = Some(count);
            result
        });
        outputs.frame(&outcome, instructions, header.world.is_some())?;
    }
    defmt::info!(
        "done: {=u32} frames, stack peak {=usize} B",
        header.records,
        stack::peak_bytes()
    );
    Ok(())
}

/// The silhouette table the clip asks for.
fn table(
    choice: TableUse,
    model: &ProjectileModel<'static>,
) -> Result<Option<Table<'static>>, Error> {
    match choice {
        TableUse::None => Ok(None),
        TableUse::Bundled => model.table().map(Some).ok_or(Error::NoBundledTable),
    }
}

/// The measured call, kept out of line so that how the compiler inlines the pipeline does not
/// depend on the code around it.
#[inline(never)]
fn process(pipeline: &mut FirmwarePipeline, frame: &FrameInput) -> FrameResult {
    pipeline.process(frame)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    semihosting::process::exit(101)
}

#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // No logging here: the fault may have hit inside the logger.
    semihosting::process::exit(102)
}
