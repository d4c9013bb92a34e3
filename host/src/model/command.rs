//! `imade model build` (also `imade lut build`): a model file from the built-in reference or
//! from the user's mesh, with its silhouette table.

use super::{DerivedModel, encode};
use crate::clip::write_atomically;
use crate::lut::build::{self, Grid, Source};
use crate::sim::mesh::Mesh;
use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use imade_core::lut::table::Table;
use imade_core::model::ProjectileModel;
use std::path::PathBuf;

/// `imade model ...` (and `imade lut ...`).
#[derive(Args, Debug)]
pub struct ModelArgs {
    #[command(subcommand)]
    command: ModelCommand,
}

#[derive(Subcommand, Debug)]
enum ModelCommand {
    /// Build a model file: the built-in reference's (`--model`) or a mesh's (`--mesh`), with its
    /// silhouette table.
    Build(BuildArgs),
    /// Write the simulator's mesh of a built-in shape (OBJ, body frame B, metres): the mesh its
    /// clips are rendered from, for `model build --mesh` or another renderer.
    Mesh(MeshArgs),
}

/// Runs `imade model`.
pub fn run(args: &ModelArgs) -> anyhow::Result<()> {
    match &args.command {
        ModelCommand::Build(b) => build_command(b),
        ModelCommand::Mesh(m) => mesh_command(m),
    }
}

/// `imade model mesh`
#[derive(Args, Debug)]
pub struct MeshArgs {
    /// Built-in shape id: `ref-1378x80` or one of the simulator's other shapes.
    #[arg(long)]
    pub shape: String,
    /// Output Wavefront OBJ file.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `imade model mesh`.
pub fn mesh_command(args: &MeshArgs) -> anyhow::Result<()> {
    let mesh = crate::sim::shapes::mesh(&args.shape).with_context(|| {
        format!(
            "no built-in shape {:?} (built in: {}, {})",
            args.shape,
            crate::sim::model::REFERENCE_ID,
            crate::sim::shapes::IDS.join(", ")
        )
    })?;
    write_atomically(&args.out, mesh.to_obj().as_bytes())?;
    println!(
        "{}: {} vertices, {} triangles",
        args.out.display(),
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    Ok(())
}

/// `imade model build`
#[derive(Args, Debug)]
pub struct BuildArgs {
    /// Built-in model id (`ref-1378x80`).
    #[arg(long, required_unless_present = "mesh", conflicts_with = "mesh")]
    pub model: Option<String>,
    /// OBJ or STL mesh in the body frame (x_B towards the nose): its radius profile and fins are
    /// derived from it, checked, and printed for you to confirm.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Metres per mesh unit.
    #[arg(long, default_value_t = 1.0)]
    pub mesh_scale: f64,
    /// Body diameter of the mesh, m, when known: checked against the mesh's (within 2 %).
    #[arg(long)]
    pub diameter: Option<f64>,
    /// Model id, as `clip.json` names it (default: the mesh file's stem).
    #[arg(long)]
    pub id: Option<String>,
    /// Embed this silhouette table (imade-lut/1) instead of building one.
    #[arg(long, conflicts_with = "no_table")]
    pub table: Option<PathBuf>,
    /// Write the model without a silhouette table (the closed form only).
    #[arg(long)]
    pub no_table: bool,
    /// Tilts of the built table, from 0 to 90 deg inclusive.
    #[arg(long, default_value_t = 91)]
    pub tilts: u16,
    /// Rolls of the built table, from 0 to 90 deg exclusive (default: 18 for a finned body; 1
    /// without fins, whose silhouette does not change with roll).
    #[arg(long)]
    pub rolls: Option<u16>,
    /// Stations per entry of the built table.
    #[arg(long, default_value_t = 96)]
    pub stations: u16,
    /// Output model file.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `imade model build`.
pub fn build_command(args: &BuildArgs) -> anyhow::Result<()> {
    let (id, model, mesh) = match (&args.model, &args.mesh) {
        (Some(id), _) => {
            if id != crate::sim::model::REFERENCE_ID {
                bail!(
                    "no built-in model {id:?} (built in: {}); give --mesh instead",
                    crate::sim::model::REFERENCE_ID
                );
            }
            (id.clone(), super::reference(), None)
        }
        (None, Some(path)) => {
            let mesh = Mesh::load(path, args.mesh_scale)?;
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
            let id = args.id.clone().unwrap_or_else(|| stem.to_owned());
            let (model, report) = crate::mesh_model::derive(&mesh, args.diameter)
                .with_context(|| format!("{}", path.display()))?;
            println!("{}:\n{report}", path.display());
            (id, model, Some(mesh))
        }
        (None, None) => bail!("give --model or --mesh"),
    };
    let table = table_bytes(args, &id, &model, mesh.as_ref())?;
    let bytes = encode(&id, &model, table.as_deref())?;
    write_atomically(&args.out, &bytes)?;
    println!(
        "{}: model {id:?}, {} bytes: length {:.1} mm, diameter {:.1} mm, {} profile stations, {}, {}",
        args.out.display(),
        bytes.len(),
        1e3 * model.length_m,
        1e3 * model.diameter_m,
        model.profile.len(),
        model
            .fins
            .map_or("no fins".to_owned(), |f| format!("{} fins", f.count)),
        table.map_or("no table".to_owned(), |t| format!(
            "table {} bytes",
            t.len()
        ))
    );
    Ok(())
}

/// The silhouette table the file carries: the given one (checked for this model), none, or one
/// built from the mesh (exact) or from the model's own geometry.
fn table_bytes(
    args: &BuildArgs,
    id: &str,
    model: &DerivedModel,
    mesh: Option<&Mesh>,
) -> anyhow::Result<Option<Vec<u8>>> {
    if args.no_table {
        return Ok(None);
    }
    let geometry = encode(id, model, None)?;
    let parsed = ProjectileModel::parse(&geometry)
        .map_err(|e| anyhow::anyhow!("the model does not validate: {e:?}"))?;
    let bytes = match &args.table {
        Some(path) => {
            std::fs::read(path).with_context(|| format!("reading table {}", path.display()))?
        }
        None => {
            let grid = Grid {
                tilts: args.tilts,
                rolls: args
                    .rolls
                    .unwrap_or(if model.fins.is_some() { 18 } else { 1 }),
                stations: args.stations,
            };
            let source = match mesh {
                Some(mesh) => Source::Mesh {
                    id,
                    mesh,
                    diameter_m: model.diameter_m as f32,
                },
                None => Source::Model(&parsed),
            };
            build::build(&source, grid)?
        }
    };
    let table = Table::parse(&bytes)
        .map_err(|e| anyhow::anyhow!("the silhouette table does not parse: {e:?}"))?;
    if !parsed.matches_table(&table) {
        bail!(
            "the silhouette table is for {:?} ({} x {} m), the model is {id:?} ({} x {} m)",
            table.model_id(),
            table.length_m(),
            table.diameter_m(),
            parsed.length_m,
            parsed.diameter_m
        );
    }
    Ok(Some(bytes))
}
