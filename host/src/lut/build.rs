//! Builds an `imade-lut/1` table (see `imade_core::lut::table` and `docs/lut-format.md`) by
//! drawing each tilt and roll's silhouette with the core's own renderer at a large scale and
//! reading its edges across the axis.

use crate::sim::mesh::Mesh;
use anyhow::{Context, ensure};
use imade_core::ImagePoint;
use imade_core::lut::render::{self, Placement, View};
use imade_core::lut::table::{
    self, CRC, HEADER_LEN, MAGIC, MODEL_ID_LEN, U_UNITS_PER_D, VERSION, grid_roll_deg,
    grid_tilt_deg,
};
use imade_core::mask::BitMask;
use imade_core::model::ProjectileModel;
use imade_core::pose::RAD;

/// Drawing scale, px per body diameter.
const PX_PER_D: f32 = 100.0;
/// Words of the drawing mask: 2 Mbit, enough for a body 20 diameters long at `PX_PER_D`.
const DRAWING_WORDS: usize = 1 << 16;
/// Headroom of the `v` quantum over the largest radius.
const V_HEADROOM: f32 = 1.02;

/// The table's grid.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    /// Tilts from 0 to 90 deg inclusive.
    pub tilts: u16,
    /// Rolls from 0 to 90 deg exclusive.
    pub rolls: u16,
    /// Stations per entry.
    pub stations: u16,
}

/// What the table is built from.
pub enum Source<'a> {
    /// A built-in parametric model.
    Model(&'a ProjectileModel<'a>),
    /// A mesh in the body frame (x_B towards the nose), m.
    Mesh {
        /// Model id written into the table.
        id: &'a str,
        /// The mesh.
        mesh: &'a Mesh,
        /// Body diameter, m.
        diameter_m: f32,
    },
}

impl Source<'_> {
    fn id(&self) -> &str {
        match self {
            Source::Model(m) => m.id(),
            Source::Mesh { id, .. } => id,
        }
    }

    fn diameter_m(&self) -> f32 {
        match self {
            Source::Model(m) => m.diameter_m,
            Source::Mesh { diameter_m, .. } => *diameter_m,
        }
    }

    /// (tail x, nose x) along the body axis, m.
    fn x_range(&self) -> (f32, f32) {
        match self {
            Source::Model(m) => (-0.5 * m.length_m, 0.5 * m.length_m),
            Source::Mesh { mesh, .. } => mesh
                .vertices
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v.x as f32), hi.max(v.x as f32))
                }),
        }
    }

    fn length_m(&self) -> f32 {
        let (lo, hi) = self.x_range();
        hi - lo
    }

    /// The largest distance of the body from its axis, m.
    fn max_radius_m(&self) -> f32 {
        match self {
            Source::Model(m) => m.max_radius_m(),
            Source::Mesh { mesh, .. } => mesh
                .vertices
                .iter()
                .map(|v| (v.y * v.y + v.z * v.z).sqrt() as f32)
                .fold(0.0, f32::max),
        }
    }

    /// Calls `f` with each silhouette-frame triangle (m) at `view`, the body origin at the
    /// middle of its length.
    fn triangles(&self, view: &View, mut f: impl FnMut([(f32, f32); 3])) {
        match self {
            Source::Model(m) => render::for_each_triangle(m, view, f),
            Source::Mesh { mesh, .. } => {
                let (lo, hi) = self.x_range();
                let mid = 0.5 * (lo + hi);
                let (sb, cb) = (view.tilt_deg * RAD).sin_cos();
                let (sp, cp) = (view.roll_deg * RAD).sin_cos();
                let project = |i: u32| {
                    let v = mesh.vertices[i as usize];
                    let (y, z) = (v.y as f32, v.z as f32);
                    // Fin angle psi measured from +v: rotate (y_B, z_B) by the roll.
                    let (r_cos, r_sin) = (y * cp - z * sp, y * sp + z * cp);
                    ((v.x as f32 - mid) * cb - r_sin * sb, r_cos)
                };
                for t in &mesh.triangles {
                    f([project(t[0]), project(t[1]), project(t[2])]);
                }
            }
        }
    }
}

/// The table's bytes.
pub fn build(source: &Source, grid: Grid) -> anyhow::Result<Vec<u8>> {
    ensure!(grid.tilts >= 2, "at least 2 tilts");
    ensure!(grid.rolls >= 1, "at least 1 roll");
    ensure!(
        (2..=table::MAX_STATIONS).contains(&usize::from(grid.stations)),
        "stations must be 2..={}",
        table::MAX_STATIONS
    );
    let id = source.id().as_bytes();
    ensure!(
        id.len() <= MODEL_ID_LEN,
        "model id longer than {MODEL_ID_LEN} bytes"
    );
    let d = source.diameter_m();
    let length = source.length_m();
    ensure!(d > 0.0 && length > 0.0, "the model has no size");
    let v_quantum = V_HEADROOM * source.max_radius_m() / d / 127.0;
    let width = ((length / d + 4.0) * PX_PER_D) as usize;
    let height = ((2.0 * source.max_radius_m() / d + 0.5) * PX_PER_D) as usize;
    let mut drawing: Box<BitMask<DRAWING_WORDS>> = Box::new(BitMask::new());
    drawing
        .reset(width, height)
        .ok()
        .context("the model is too long for the drawing mask")?;
    let mut bytes = header(source, grid, v_quantum);
    for i in 0..grid.tilts {
        for j in 0..grid.rolls {
            let view = View {
                tilt_deg: grid_tilt_deg(i.into(), grid.tilts.into()),
                roll_deg: grid_roll_deg(j.into(), grid.rolls.into()),
            };
            entry(
                source,
                &view,
                grid.stations,
                v_quantum,
                &mut drawing,
                &mut bytes,
            );
        }
    }
    let crc = CRC.checksum(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    Ok(bytes)
}

fn header(source: &Source, grid: Grid, v_quantum: f32) -> Vec<u8> {
    let mut h = Vec::with_capacity(HEADER_LEN);
    h.extend_from_slice(&MAGIC);
    h.extend_from_slice(&VERSION.to_le_bytes());
    h.extend_from_slice(&(HEADER_LEN as u16).to_le_bytes());
    let mut id = [0u8; MODEL_ID_LEN];
    id[..source.id().len()].copy_from_slice(source.id().as_bytes());
    h.extend_from_slice(&id);
    h.extend_from_slice(&source.diameter_m().to_le_bytes());
    h.extend_from_slice(&source.length_m().to_le_bytes());
    h.extend_from_slice(&grid.tilts.to_le_bytes());
    h.extend_from_slice(&grid.rolls.to_le_bytes());
    h.extend_from_slice(&grid.stations.to_le_bytes());
    h.extend_from_slice(&0u16.to_le_bytes());
    h.extend_from_slice(&v_quantum.to_le_bytes());
    h
}

/// Draws one view and appends its entry.
fn entry(
    source: &Source,
    view: &View,
    stations: u16,
    v_quantum: f32,
    drawing: &mut BitMask<DRAWING_WORDS>,
    out: &mut Vec<u8>,
) {
    let d = source.diameter_m();
    let (w, h) = (drawing.width(), drawing.height());
    let centre = ImagePoint::new((w / 2) as f32, (h / 2) as f32);
    let placement = Placement {
        origin: centre,
        dir: ImagePoint::new(1.0, 0.0),
        px_per_unit: PX_PER_D / d,
    };
    drawing.clear();
    let (mut u_lo, mut u_hi) = (f32::INFINITY, f32::NEG_INFINITY);
    source.triangles(view, |t| {
        for (u, _) in t {
            u_lo = u_lo.min(u / d);
            u_hi = u_hi.max(u / d);
        }
        // An infallible target: drawing cannot fail.
        let _ = render::fill_triangle(drawing, &placement, t);
    });
    // Each column's first and last set rows, as edges in D (pixel centres at integers).
    let column_edges = |x: usize| -> Option<(f32, f32)> {
        let first = (0..h).find(|&y| drawing.get(x, y))?;
        let last = (0..h).rev().find(|&y| drawing.get(x, y))?;
        Some((
            (first as f32 - 0.5 - centre.y) / PX_PER_D,
            (last as f32 + 0.5 - centre.y) / PX_PER_D,
        ))
    };
    let edges: Vec<Option<(f32, f32)>> = (0..w).map(column_edges).collect();
    let at = |u: f32| -> (f32, f32) {
        let x = u * PX_PER_D + centre.x;
        let x0 = (x.floor().max(0.0) as usize).min(w - 2);
        let f = (x - x0 as f32).clamp(0.0, 1.0);
        match (edges[x0], edges[x0 + 1]) {
            (Some(a), Some(b)) => (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1)),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => (0.0, 0.0),
        }
    };
    let quantize_u = |u: f32| ((u * U_UNITS_PER_D).round() as i16).to_le_bytes();
    out.extend_from_slice(&quantize_u(u_lo));
    out.extend_from_slice(&quantize_u(u_hi));
    let quantize_v = |v: f32| (v / v_quantum).round().clamp(-127.0, 127.0) as i8 as u8;
    for s in 0..stations {
        let u = u_lo + (u_hi - u_lo) * f32::from(s) / f32::from(stations - 1);
        let (lo, hi) = at(u);
        out.push(quantize_v(lo));
        out.push(quantize_v(hi));
    }
}
