//! `imade lut`: silhouette tables (`imade-lut/1`) for the core's table match; building them and
//! finding the one for a model.

pub mod build;

use crate::clip::write_atomically;
use crate::sim::mesh::Mesh;
use anyhow::{Context, bail};
use build::{Grid, Source};
use clap::{Args, Subcommand};
use imade_core::lut::table::Table;
use imade_core::model::{ProjectileModel, built_in_model};
use std::path::{Path, PathBuf};

/// `imade lut ...`
#[derive(Args)]
pub struct LutArgs {
    #[command(subcommand)]
    command: LutCommand,
}

#[derive(Subcommand)]
enum LutCommand {
    /// Build a table: a built-in model's (`--model`) or a mesh's (`--mesh`).
    Build(BuildArgs),
}

/// `imade lut build`
#[derive(Args)]
pub struct BuildArgs {
    /// Built-in model id.
    #[arg(long, required_unless_present = "mesh", conflicts_with = "mesh")]
    model: Option<String>,
    /// OBJ or STL mesh in the body frame (x_B towards the nose).
    #[arg(long, requires = "diameter")]
    mesh: Option<PathBuf>,
    /// Metres per mesh unit.
    #[arg(long, default_value_t = 1.0)]
    mesh_scale: f64,
    /// Body diameter of the mesh, m.
    #[arg(long)]
    diameter: Option<f32>,
    /// Model id written into a mesh's table (default: the file stem).
    #[arg(long)]
    id: Option<String>,
    /// Tilts from 0 to 90 deg inclusive.
    #[arg(long, default_value_t = 91)]
    tilts: u16,
    /// Rolls from 0 to 90 deg exclusive.
    #[arg(long, default_value_t = 18)]
    rolls: u16,
    /// Stations per entry.
    #[arg(long, default_value_t = 96)]
    stations: u16,
    /// Output file.
    #[arg(long)]
    out: PathBuf,
}

/// Runs `imade lut`.
pub fn run(args: &LutArgs) -> anyhow::Result<()> {
    match &args.command {
        LutCommand::Build(b) => build_command(b),
    }
}

fn build_command(args: &BuildArgs) -> anyhow::Result<()> {
    let grid = Grid {
        tilts: args.tilts,
        rolls: args.rolls,
        stations: args.stations,
    };
    let bytes = match (&args.model, &args.mesh) {
        (Some(id), _) => {
            let model = built_in_model(id)
                .with_context(|| format!("no built-in model {id:?} (give --mesh instead)"))?;
            build::build(&Source::Model(model), grid)?
        }
        (None, Some(path)) => {
            let mesh = Mesh::load(path, args.mesh_scale)?;
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
            let id = args.id.as_deref().unwrap_or(stem);
            let diameter_m = args.diameter.context("--mesh needs --diameter")?;
            build::build(
                &Source::Mesh {
                    id,
                    mesh: &mesh,
                    diameter_m,
                },
                grid,
            )?
        }
        (None, None) => bail!("give --model or --mesh"),
    };
    Table::parse(&bytes).map_err(|e| anyhow::anyhow!("the built table does not parse: {e:?}"))?;
    write_atomically(&args.out, &bytes)?;
    println!(
        "{}: {} bytes, {} tilts x {} rolls x {} stations",
        args.out.display(),
        bytes.len(),
        grid.tilts,
        grid.rolls,
        grid.stations
    );
    Ok(())
}

/// Where the bundled tables live: `fixtures/lut/` of the source tree.
pub fn bundled_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/lut")
}

/// Reads and validates the table at `path` for `model`, keeping its bytes for the life of the
/// process (the core borrows tables as `&'static [u8]`, as from flash).
pub fn load(path: &Path, model: &ProjectileModel) -> anyhow::Result<Table<'static>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading table {}", path.display()))?;
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    Table::parse_for(bytes, model)
        .map_err(|e| anyhow::anyhow!("{}: not a table for {}: {e:?}", path.display(), model.id))
}

/// The table a run asks for: `bundled` (the bundled table of `model`, if there is one), `none`,
/// or a table file.
pub fn table_for(choice: &str, model: &ProjectileModel) -> anyhow::Result<Option<Table<'static>>> {
    match choice {
        "none" => Ok(None),
        "bundled" => {
            let path = bundled_dir().join(format!("{}.lut", model.id));
            if path.exists() {
                load(&path, model).map(Some)
            } else {
                Ok(None)
            }
        }
        file => load(Path::new(file), model).map(Some),
    }
}
