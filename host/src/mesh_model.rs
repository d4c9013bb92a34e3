//! From the user's projectile mesh to the a priori model: the body of revolution's profile, its
//! diameter and the fins' planform, derived by cutting the mesh across its axis.
//!
//! The mesh is in body frame B, in metres (after the mesh scale): origin anywhere on the axis,
//! +x_B along the axis towards the nose. s is the distance aft of the nose tip.
//!
//! [`derive()`] checks that the mesh is closed (after welding coincident vertices, so that STL
//! triangle soups pass), that its principal axis is x_B and its size plausible, then cuts it with
//! [`STATIONS`] planes x = const. In each cut it takes the largest radius of the cut's outline in
//! each of [`SECTORS`] roll sectors (the outline's segments are clipped to the sectors exactly,
//! so coarse meshes with few vertices are measured as well as fine ones). Sectors that stand out
//! from the cut's median sector radius by more than [`FIN_EXCESS`] of the body radius, at two
//! stations or more, are fin sectors, grouped into roll clusters, one per fin. The other sectors
//! give the body: their offset from the axis (opposite sectors compared), their spread (the
//! axisymmetry residual) and the body radius, their 90 % quantile (the radius of a faceted mesh's
//! vertices, where the median would fall between vertices).
//!
//! A base with fins reaching beyond it is found where the body ends (by bisection on extra cuts);
//! the length is to the base, not to the fins' trailing edges.
//!
//! Each fin's roll angle, tip chord, tip radius and thickness come from the mesh vertices in its
//! cluster (a flat-faced fin's extremes are vertices). Its root chord comes from where the fin
//! leaves the body: the stations where it stands out are refined by bisection on extra cuts, then
//! extended along the leading and trailing edges down to the body surface.
//!
//! The profile is the body radius at the stations, simplified (Douglas-Peucker on the radius,
//! tolerance 0.1 % of the diameter, keeping the tip, the nose's shoulder, the start of a boat tail
//! and the base) to at most [`MAX_PROFILE_STATIONS`] stations.

use crate::sim::math::Vec3;
use crate::sim::mesh::Mesh;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::fmt;

/// Cutting planes across the axis, evenly spaced from the nose tip to the aft end.
pub const STATIONS: usize = 400;
/// Roll sectors of each cut.
pub const SECTORS: usize = 72;
/// Most stations in the derived profile.
pub const MAX_PROFILE_STATIONS: usize = 64;
/// A fin sector stands out from the body radius by more than this share of the body's largest
/// radius.
pub const FIN_EXCESS: f64 = 0.10;
/// Plausible lengths after scaling, m.
const LENGTH_RANGE_M: (f64, f64) = (0.05, 50.0);
/// Largest angle between the mesh's principal axis and x_B, deg.
const MAX_AXIS_TILT_DEG: f64 = 3.0;
/// Largest spread of the non-fin sector radii at a station, as a share of the body's largest
/// radius (a 12-sided body spreads 3.4 %).
const AXISYMMETRY_TOLERANCE: f64 = 0.05;
/// Largest distance of the body's sections' centre from the x_B axis, as a share of the diameter.
const MAX_OFF_AXIS: f64 = 0.02;
/// A run of more sectors than this is not a fin (45 deg).
const MAX_FIN_SECTORS: usize = SECTORS / 8;
/// A fin cluster whose excess area is below this share of the largest cluster's is a protrusion
/// (a launch lug, a rail button), not a fin.
const MIN_FIN_SHARE: f64 = 0.25;
/// Largest deviation of a fin's roll angle from even spacing, deg.
const FIN_SPACING_TOLERANCE_DEG: f64 = 3.0;
/// Fins whose planforms differ by more than this are reported, m.
const FIN_MISMATCH_M: f64 = 1e-3;
/// Largest relative difference between a given diameter and the derived one.
const DIAMETER_TOLERANCE: f64 = 0.02;
/// Douglas-Peucker tolerance of the profile, as a share of the diameter.
const PROFILE_TOLERANCE: f64 = 1e-3;
/// The body is at full radius within this share of its largest radius (an exact tangent ogive's
/// shoulder is found this way about 1 % of its length ahead of the tangent point).
const FULL_RADIUS: f64 = 1e-4;
/// A base radius smaller than the largest by more than this share is a boat tail.
const BOAT_TAIL: f64 = 0.01;
/// The end cuts are this share of the length inside the mesh's ends.
const END_OFFSET: f64 = 1e-6;
/// Vertices of a fin's tip chord are within this share of the tip radius from it.
const TIP_TOLERANCE: f64 = 2e-3;
/// Bisection steps when refining a boundary between two stations.
const BISECTIONS: usize = 24;

pub use crate::model::{DerivedModel, FinPlanform};

/// What [`derive()`] found, for the user to confirm before the model is used.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshReport {
    /// Vertices in the mesh.
    pub vertices: usize,
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Angle between the mesh's principal axis and x_B, deg.
    pub axis_tilt_deg: f64,
    /// Nose tip to base, m.
    pub length_m: f64,
    /// Extent along x_B, m: the length, or more when fins reach beyond the base.
    pub overall_length_m: f64,
    /// The body's largest diameter, m.
    pub diameter_m: f64,
    /// Diameter of a flat nose tip (0 for a pointed nose), m.
    pub nose_flat_diameter_m: f64,
    /// s where the body first reaches its full diameter, m.
    pub nose_length_m: f64,
    /// s where a boat tail starts (the body last at full diameter), if there is one, m.
    pub boat_tail_start_m: Option<f64>,
    /// Diameter of the base, m.
    pub base_diameter_m: f64,
    /// Stations in the profile.
    pub profile_stations: usize,
    /// Largest radius error of the profile against the cuts, m.
    pub profile_tolerance_m: f64,
    /// Largest spread of the body radius around the axis (fins left out), m.
    pub axisymmetry_residual_m: f64,
    /// s of that largest spread, m.
    pub axisymmetry_residual_s_m: f64,
    /// Tolerance of that spread, m.
    pub axisymmetry_tolerance_m: f64,
    /// The fins found (as in the model).
    pub fins: Option<FinPlanform>,
    /// Roll angle of each fin, deg, from +y_B towards +z_B, ascending.
    pub fin_roll_deg: Vec<f64>,
    /// What looked odd but did not stop the derivation.
    pub warnings: Vec<String>,
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mm = |m: f64| m * 1e3;
        writeln!(
            f,
            "mesh: {} vertices, {} triangles, closed, axis along x_B (within {:.2} deg)",
            self.vertices, self.triangles, self.axis_tilt_deg
        )?;
        write!(
            f,
            "length {:.1} mm (nose tip to base), body diameter {:.1} mm",
            mm(self.length_m),
            mm(self.diameter_m)
        )?;
        if self.overall_length_m > self.length_m + 1e-6 {
            write!(f, ", overall {:.1} mm", mm(self.overall_length_m))?;
        }
        writeln!(f)?;
        if self.nose_flat_diameter_m > 0.0 {
            write!(
                f,
                "nose: blunt (flat tip {:.1} mm across)",
                mm(self.nose_flat_diameter_m)
            )?;
        } else {
            write!(f, "nose: pointed")?;
        }
        writeln!(f, ", full diameter from {:.1} mm", mm(self.nose_length_m))?;
        match self.boat_tail_start_m {
            Some(s) => writeln!(
                f,
                "boat tail: yes, from {:.1} mm, base diameter {:.1} mm",
                mm(s),
                mm(self.base_diameter_m)
            )?,
            None => writeln!(
                f,
                "boat tail: no, base diameter {:.1} mm",
                mm(self.base_diameter_m)
            )?,
        }
        writeln!(
            f,
            "profile: {} stations (within {:.2} mm of the cuts)",
            self.profile_stations,
            mm(self.profile_tolerance_m)
        )?;
        match &self.fins {
            None => writeln!(f, "fins: none")?,
            Some(fins) => {
                let rolls: Vec<String> = self
                    .fin_roll_deg
                    .iter()
                    .map(|a| format!("{a:.1}"))
                    .collect();
                writeln!(
                    f,
                    "fins: {} at roll {} deg (from +y_B towards +z_B); root chord {:.1} .. {:.1} mm ({:.1} mm), tip chord {:.1} .. {:.1} mm ({:.1} mm) at {:.1} mm from the axis, thickness {:.1} mm",
                    fins.count,
                    rolls.join(", "),
                    mm(fins.root_le_s),
                    mm(fins.root_te_s),
                    mm(fins.root_te_s - fins.root_le_s),
                    mm(fins.tip_le_s),
                    mm(fins.tip_te_s),
                    mm(fins.tip_te_s - fins.tip_le_s),
                    mm(fins.tip_radius_m),
                    mm(fins.thickness_m)
                )?;
            }
        }
        writeln!(
            f,
            "axisymmetry residual: {:.2} mm at {:.1} mm (tolerance {:.2} mm)",
            mm(self.axisymmetry_residual_m),
            mm(self.axisymmetry_residual_s_m),
            mm(self.axisymmetry_tolerance_m)
        )?;
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}

/// Why a mesh cannot be turned into a model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshModelError {
    /// No triangles or no vertices.
    #[error("the mesh is empty: it has no triangles")]
    Empty,
    /// Non-finite coordinates, missing vertices, no surface.
    #[error("the mesh is not usable: {0}")]
    Invalid(String),
    /// Some edges do not have a triangle on each side.
    #[error(
        "the mesh is not closed: {open_edges} edge(s) belong to one triangle only (or to an odd number), the first near ({:.1}, {:.1}, {:.1}) mm in B; the body's cuts need a closed (watertight) surface",
        near_m[0] * 1e3, near_m[1] * 1e3, near_m[2] * 1e3
    )]
    NotClosed {
        /// Edges with an odd number of triangles.
        open_edges: usize,
        /// The middle of one of them, m.
        near_m: [f64; 3],
    },
    /// The mesh's principal axis is not x_B.
    #[error(
        "the mesh's principal axis is {angle_deg:.1} deg off x_B (it runs along ({:.3}, {:.3}, {:.3})): give the mesh with +x_B along the projectile's axis, towards the nose",
        axis[0], axis[1], axis[2]
    )]
    NotAlongX {
        /// Angle between the principal axis and x_B, deg.
        angle_deg: f64,
        /// The principal axis, a unit vector in B.
        axis: [f64; 3],
    },
    /// Implausible length after scaling.
    #[error(
        "the mesh is {length_m:.4} m long after scaling, outside {} m .. {} m: check --mesh-scale (metres per mesh unit: 0.001 for a mesh in mm, 0.0254 in inches)",
        LENGTH_RANGE_M.0, LENGTH_RANGE_M.1
    )]
    AbsurdSize {
        /// The mesh's extent along x_B, m.
        length_m: f64,
    },
    /// The body is not centred on the x_B axis.
    #[error(
        "the mesh's body is {:.1} mm off the x_B axis (its sections are centred at y = {:.1} mm, z = {:.1} mm; at most {:.1} mm): the origin must be on the projectile's axis",
        offset_m * 1e3, y_m * 1e3, z_m * 1e3, tolerance_m * 1e3
    )]
    OffAxis {
        /// Distance of the body's axis from x_B (the median over the cuts), m.
        offset_m: f64,
        /// Its y_B, m.
        y_m: f64,
        /// Its z_B, m.
        z_m: f64,
        /// The largest distance accepted, m.
        tolerance_m: f64,
    },
    /// The body's radius varies around the axis.
    #[error(
        "the mesh is not a body of revolution about x_B: {:.1} mm aft of the nose tip its radius varies by {:.2} mm around the axis outside the fins (tolerance {:.2} mm)",
        s_m * 1e3, spread_m * 1e3, tolerance_m * 1e3
    )]
    NotAxisymmetric {
        /// Where the spread is largest, m aft of the nose tip.
        s_m: f64,
        /// Largest minus smallest radius there, fins left out, m.
        spread_m: f64,
        /// The largest spread accepted, m.
        tolerance_m: f64,
    },
    /// Fins that are not two or more evenly spaced in roll.
    #[error(
        "found {} fin(s) at roll {} deg (from +y_B towards +z_B): the model needs two or more identical fins evenly spaced in roll (within {} deg)",
        roll_deg.len(), list_deg(roll_deg), FIN_SPACING_TOLERANCE_DEG
    )]
    UnevenFins {
        /// The fins' roll angles, deg.
        roll_deg: Vec<f64>,
    },
    /// A diameter given with the mesh disagrees with the mesh's.
    #[error(
        "the given diameter {:.1} mm disagrees with the mesh's {:.1} mm by {:+.1} % (more than {} %): check the diameter or --mesh-scale",
        given * 1e3, derived * 1e3, 100.0 * (given / derived - 1.0), DIAMETER_TOLERANCE * 100.0
    )]
    DiameterMismatch {
        /// The diameter given, m.
        given: f64,
        /// The mesh's body diameter, m.
        derived: f64,
    },
}

fn list_deg(angles: &[f64]) -> String {
    let parts: Vec<String> = angles.iter().map(|a| format!("{a:.1}")).collect();
    parts.join(", ")
}

/// Derives the model description from a mesh in B (m), checking it against a diameter the user
/// gave, if any.
pub fn derive(
    mesh: &Mesh,
    expected_diameter_m: Option<f64>,
) -> Result<(DerivedModel, MeshReport), MeshModelError> {
    if mesh.triangles.is_empty() || mesh.vertices.is_empty() {
        return Err(MeshModelError::Empty);
    }
    mesh.check()
        .map_err(|e| MeshModelError::Invalid(format!("{e:#}")))?;
    let mut warnings = Vec::new();

    let edges = check_closed(mesh)?;
    if edges.non_manifold > 0 {
        warnings.push(format!(
            "{} edge(s) are shared by more than two triangles (parts touching along an edge); the cuts take the outer surface",
            edges.non_manifold
        ));
    }
    // A closed surface wound outwards encloses a positive volume (the divergence theorem).
    let volume: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    if edges.misoriented == 0 && volume < 0.0 {
        warnings.push(
            "the triangles are wound facing inwards (the cuts do not need them outwards, but a renderer that culls back faces draws nothing)"
                .to_string(),
        );
    }
    if edges.misoriented > 0 {
        warnings.push(format!(
            "{} edge(s) join triangles wound the same way round: the surface's facing is not consistent (the cuts do not need it, but a renderer that culls back faces leaves those triangles out)",
            edges.misoriented
        ));
    }

    let moments = SurfaceMoments::of(mesh);
    if moments.area <= 0.0 {
        return Err(MeshModelError::Invalid(
            "its triangles have no area".to_string(),
        ));
    }
    let axis_tilt_deg = check_axis(&moments, &mut warnings)?;

    // Vertices no triangle uses are left out.
    let mut used = vec![false; mesh.vertices.len()];
    for &i in mesh.triangles.iter().flatten() {
        used[i as usize] = true;
    }
    let (x_min, x_max) = mesh
        .vertices
        .iter()
        .zip(&used)
        .filter(|&(_, &u)| u)
        .map(|(v, _)| v)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v.x), hi.max(v.x))
        });
    let overall = x_max - x_min;
    if !(LENGTH_RANGE_M.0..=LENGTH_RANGE_M.1).contains(&overall) {
        return Err(MeshModelError::AbsurdSize { length_m: overall });
    }

    // The cuts.
    let slicer = Slicer::new(mesh, x_max, overall);
    let h = slicer.h;
    let s_at = |i: usize| i as f64 * h;
    let cuts = slicer.sweep();
    let medians: Vec<f64> = cuts.iter().map(median).collect();
    let r_max = medians.iter().copied().fold(0.0, f64::max);
    if r_max <= 0.0 {
        return Err(MeshModelError::Invalid(
            "no body around the x_B axis".to_string(),
        ));
    }
    let body_eps = 1e-6 * r_max;

    // The base: the last station with a body (beyond it, only fins reach aft).
    let last = medians
        .iter()
        .rposition(|&r| r > body_eps)
        .expect("r_max > 0");
    let length = if last == STATIONS - 1 {
        overall
    } else {
        let end = boundary(s_at(last), s_at(last + 1), |s| {
            median(&slicer.at(s)) > body_eps
        });
        // A flat base is a plane of vertices: snap to it.
        let nearest = mesh
            .vertices
            .iter()
            .zip(&used)
            .filter(|&(_, &u)| u)
            .map(|(v, _)| x_max - v.x)
            .min_by(|a, b| (a - end).abs().total_cmp(&(b - end).abs()))
            .expect("used vertices");
        if (nearest - end).abs() < END_OFFSET * overall {
            nearest
        } else {
            end
        }
    };

    // Fin sectors: those that stand out from the body at two stations or more, in runs narrower
    // than a fin can be (wider ones are left to the axisymmetry check).
    let fin_excess = FIN_EXCESS * r_max;
    let mut hits = [0usize; SECTORS];
    for (cut, &body) in cuts.iter().zip(&medians) {
        for (k, &r) in cut.iter().enumerate() {
            if r - body > fin_excess {
                hits[k] += 1;
            }
        }
    }
    let clusters: Vec<Cluster> = circular_runs(&hits.map(|n| n >= 2))
        .into_iter()
        .filter(|c| c.sectors.len() <= MAX_FIN_SECTORS)
        .collect();
    let mut excluded = [false; SECTORS];
    for c in &clusters {
        for &k in &c.wide {
            excluded[k] = true;
        }
    }
    let kept_sectors = excluded.iter().filter(|&&x| !x).count();
    let axis_tolerance = AXISYMMETRY_TOLERANCE * r_max;
    if kept_sectors < SECTORS / 4 {
        return Err(MeshModelError::NotAxisymmetric {
            s_m: 0.5 * length,
            spread_m: fin_excess,
            tolerance_m: axis_tolerance,
        });
    }

    // Is the body centred on the axis? The offset of each cut's outline from the axis, from
    // opposite sectors outside the fins, median over the stations.
    let body_stations: Vec<usize> = (0..=last).filter(|&i| medians[i] > 0.3 * r_max).collect();
    let offsets: Vec<[f64; 2]> = body_stations
        .iter()
        .filter_map(|&i| outline_offset(&cuts[i], &excluded))
        .collect();
    if !offsets.is_empty() {
        let middle = |c: usize| {
            let mut v: Vec<f64> = offsets.iter().map(|o| o[c]).collect();
            v.sort_unstable_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (y, z) = (middle(0), middle(1));
        let offset = libm::hypot(y, z);
        let tolerance = MAX_OFF_AXIS * 2.0 * r_max;
        if offset > tolerance {
            return Err(MeshModelError::OffAxis {
                offset_m: offset,
                y_m: y,
                z_m: z,
                tolerance_m: tolerance,
            });
        }
        if offset > 0.1 * tolerance {
            warnings.push(format!(
                "the body's axis is {:.2} mm off the x_B axis (y {:.2} mm, z {:.2} mm)",
                offset * 1e3,
                y * 1e3,
                z * 1e3
            ));
        }
    }

    // Axisymmetry outside the fin sectors.
    let mut residual = (0.0, 0.0);
    for i in 0..=last {
        if medians[i] <= body_eps {
            continue;
        }
        let (lo, hi) = cuts[i]
            .iter()
            .zip(&excluded)
            .filter(|&(_, &x)| !x)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), (&r, _)| {
                (lo.min(r), hi.max(r))
            });
        if hi - lo > residual.0 {
            residual = (hi - lo, s_at(i));
        }
    }
    if residual.0 > axis_tolerance {
        return Err(MeshModelError::NotAxisymmetric {
            s_m: residual.1,
            spread_m: residual.0,
            tolerance_m: axis_tolerance,
        });
    }
    if residual.0 > 0.4 * axis_tolerance {
        warnings.push(format!(
            "the body's radius varies by {:.2} mm around the axis (a coarse mesh?)",
            residual.0 * 1e3
        ));
    }

    // The body's radius at each station: a high quantile of the sectors outside the fins, which
    // is the radius of a faceted mesh's vertices.
    let radii: Vec<f64> = cuts.iter().map(|c| body_radius(c, &excluded)).collect();
    let r_max = radii[..=last].iter().copied().fold(0.0, f64::max);
    let diameter = 2.0 * r_max;

    // The body's ends and the profile.
    let tip_face = {
        let tol = 1e-9 * overall;
        mesh.triangles.iter().any(|t| {
            let p = t.map(|i| mesh.vertices[i as usize]);
            p.iter().all(|v| x_max - v.x <= tol) && (p[1] - p[0]).cross(p[2] - p[0]).norm() > 0.0
        })
    };
    // A tip face narrower than the profile's tolerance is a tessellation's closing facet, and the
    // nose pointed.
    let r_tip = if tip_face && radii[0] > PROFILE_TOLERANCE * diameter {
        radii[0]
    } else {
        0.0
    };
    let r_base = body_radius(&slicer.at(length - END_OFFSET * overall), &excluded);
    let mut samples = vec![(0.0, r_tip)];
    samples.extend(
        (1..STATIONS)
            .map(|i| (s_at(i), radii[i]))
            .filter(|&(s, _)| s < length - 1e-9 * overall),
    );
    samples.push((length, r_base));
    let full = r_max * (1.0 - FULL_RADIUS);
    let shoulder = samples
        .iter()
        .position(|p| p.1 >= full)
        .unwrap_or(samples.len() - 1);
    let mut tail = samples
        .iter()
        .rposition(|p| p.1 >= full)
        .unwrap_or(shoulder)
        .max(shoulder);
    let boat_tail = r_base < r_max * (1.0 - BOAT_TAIL);
    // The shoulder and the start of a boat tail between stations, by bisection on extra cuts.
    let radius_at = |s: f64| body_radius(&slicer.at(s), &excluded);
    if shoulder > 0 {
        let (a, b) = (samples[shoulder].0, samples[shoulder - 1].0);
        let s = boundary(a, b, |s| radius_at(s) >= full);
        if s < a && s > b {
            samples.insert(shoulder, (s, radius_at(s)));
            tail += 1;
        }
    }
    if boat_tail && tail + 1 < samples.len() {
        let (a, b) = (samples[tail].0, samples[tail + 1].0);
        let s = boundary(a, b, |s| radius_at(s) >= full);
        if s > a && s < b {
            samples.insert(tail + 1, (s, radius_at(s)));
            tail += 1;
        }
    }
    let mut forced = vec![0, shoulder, samples.len() - 1];
    if boat_tail {
        forced.push(tail);
    }
    let mut tolerance = PROFILE_TOLERANCE * diameter;
    let kept = loop {
        let kept = simplify(&samples, &forced, tolerance);
        if kept.len() <= MAX_PROFILE_STATIONS {
            break kept;
        }
        tolerance *= 1.5;
    };
    if tolerance > PROFILE_TOLERANCE * diameter {
        warnings.push(format!(
            "the profile needed a tolerance of {:.2} mm to fit {MAX_PROFILE_STATIONS} stations",
            tolerance * 1e3
        ));
    }
    let profile: Vec<(f64, f64)> = kept.iter().map(|&i| samples[i]).collect();
    // The model's diameter is its profile's widest (the simplification may drop the widest
    // sample, by less than its tolerance), so that the file's radii never exceed it.
    let diameter = 2.0 * profile.iter().map(|p| p.1).fold(0.0, f64::max);
    if tip_face && r_tip > 0.5 * r_max && r_base < 0.1 * r_max {
        warnings.push(
            "the front end is flat and the aft end pointed: is +x_B towards the nose?".to_string(),
        );
    }
    // The body radius at any s (0 beyond the base).
    let body_at = |s: f64| -> f64 {
        if s > length + END_OFFSET * overall {
            return 0.0;
        }
        let i = samples
            .partition_point(|p| p.0 <= s)
            .clamp(1, samples.len() - 1);
        let ((s0, r0), (s1, r1)) = (samples[i - 1], samples[i]);
        r0 + (r1 - r0) * ((s - s0) / (s1 - s0)).clamp(0.0, 1.0)
    };

    // The fins.
    let ctx = FinContext {
        mesh,
        used: &used,
        slicer: &slicer,
        cuts: &cuts,
        radii: &radii,
        excluded: &excluded,
        h,
        x_nose: x_max,
        overall,
        length,
        fin_excess,
        body_at: &body_at,
    };
    let mut found: Vec<(Cluster, Run)> = Vec::new();
    for cluster in clusters {
        match ctx.main_run(&cluster, &mut warnings) {
            Some(run) => found.push((cluster, run)),
            None => continue,
        }
    }
    let largest = found.iter().map(|(_, r)| r.area).fold(0.0, f64::max);
    let mut fins: Vec<Fin> = Vec::new();
    for (cluster, run) in &found {
        if run.area < MIN_FIN_SHARE * largest {
            warnings.push(format!(
                "ignored a protrusion at roll {:.0} deg, {:.1} .. {:.1} mm aft of the tip, {:.1} mm high: smaller than the fins",
                cluster.centre_deg(),
                s_at(run.first) * 1e3,
                s_at(run.last) * 1e3,
                run.height * 1e3
            ));
            continue;
        }
        match ctx.fin(cluster, run) {
            Some(fin) => fins.push(fin),
            None => warnings.push(format!(
                "ignored what stands out at roll {:.0} deg: no vertices there",
                cluster.centre_deg()
            )),
        }
    }
    let (fin_planform, fin_roll_deg) = if fins.is_empty() {
        (None, Vec::new())
    } else {
        let (planform, rolls) = combine_fins(&mut fins, &mut warnings)?;
        if planform.tip_te_s > length + 1e-6 * overall {
            warnings.push(format!(
                "the fins reach {:.1} mm beyond the base (overall length {:.1} mm)",
                (planform.tip_te_s - length) * 1e3,
                overall * 1e3
            ));
        }
        if planform.root_te_s < 0.5 * length {
            warnings.push("the fins are in the front half: is +x_B towards the nose?".to_string());
        }
        (Some(planform), rolls)
    };

    if let Some(given) = expected_diameter_m {
        if given.is_nan() || (given - diameter).abs() > DIAMETER_TOLERANCE * diameter {
            return Err(MeshModelError::DiameterMismatch {
                given,
                derived: diameter,
            });
        }
    }

    let report = MeshReport {
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        axis_tilt_deg,
        length_m: length,
        overall_length_m: overall,
        diameter_m: diameter,
        nose_flat_diameter_m: 2.0 * r_tip,
        nose_length_m: samples[shoulder].0,
        boat_tail_start_m: boat_tail.then(|| samples[tail].0),
        base_diameter_m: 2.0 * r_base,
        profile_stations: profile.len(),
        profile_tolerance_m: tolerance,
        axisymmetry_residual_m: residual.0,
        axisymmetry_residual_s_m: residual.1,
        axisymmetry_tolerance_m: axis_tolerance,
        fins: fin_planform,
        fin_roll_deg,
        warnings,
    };
    let model = DerivedModel {
        length_m: length,
        diameter_m: diameter,
        profile,
        fins: fin_planform,
    };
    Ok((model, report))
}

/// What [`check_closed`] counted beside the open edges.
struct EdgeCounts {
    /// Edges with more than two triangles.
    non_manifold: usize,
    /// Edges that their triangles do not traverse as often one way as the other (neighbours
    /// wound the same way round).
    misoriented: usize,
}

/// Checks that every edge has an even number of triangles (two, for a manifold) after welding
/// vertices at the same position; counts the edges with more than two and those whose
/// triangles are not wound consistently.
fn check_closed(mesh: &Mesh) -> Result<EdgeCounts, MeshModelError> {
    let mut index: HashMap<[u64; 3], u32> = HashMap::with_capacity(mesh.vertices.len());
    let mut representative: Vec<Vec3> = Vec::new();
    let welded: Vec<u32> = mesh
        .vertices
        .iter()
        .map(|v| {
            // + 0.0 turns -0.0 into 0.0.
            let key = [v.x, v.y, v.z].map(|c| (c + 0.0).to_bits());
            *index.entry(key).or_insert_with(|| {
                representative.push(*v);
                u32::try_from(representative.len() - 1).expect("vertex count fits in u32")
            })
        })
        .collect();
    // Per undirected edge (lower index first): its triangles, and how many traverse it upwards
    // less how many downwards.
    let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * mesh.triangles.len());
    let mut turns: HashMap<(u32, u32), i32> = HashMap::with_capacity(3 * mesh.triangles.len());
    for t in &mesh.triangles {
        let w = t.map(|i| welded[i as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] {
            continue;
        }
        for (a, b) in [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])] {
            let key = (a.min(b), a.max(b));
            *edges.entry(key).or_insert(0) += 1;
            *turns.entry(key).or_insert(0) += if a < b { 1 } else { -1 };
        }
    }
    let open = edges
        .iter()
        .filter(|&(_, &n)| n % 2 == 1)
        .map(|(&e, _)| e)
        .min();
    if let Some((a, b)) = open {
        let open_edges = edges.values().filter(|&&n| n % 2 == 1).count();
        let mid = (representative[a as usize] + representative[b as usize]) * 0.5;
        return Err(MeshModelError::NotClosed {
            open_edges,
            near_m: [mid.x, mid.y, mid.z],
        });
    }
    Ok(EdgeCounts {
        non_manifold: edges.values().filter(|&&n| n > 2).count(),
        misoriented: turns.values().filter(|&&d| d != 0).count(),
    })
}

/// Area and central second moments of a mesh's surface.
struct SurfaceMoments {
    area: f64,
    covariance: [[f64; 3]; 3],
}

impl SurfaceMoments {
    fn of(mesh: &Mesh) -> SurfaceMoments {
        // Relative to a vertex, for precision far from the origin.
        let o = mesh.vertices[0];
        let mut area = 0.0;
        let mut first = Vec3::default();
        let mut second = [[0.0; 3]; 3];
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize] - o);
            let da = 0.5 * (b - a).cross(c - a).norm();
            let m = (a + b + c) * (1.0 / 3.0);
            area += da;
            first = first + m * da;
            // The integral of p p^T over a triangle: A / 12 (sum of v v^T + 9 m m^T).
            let (va, vb, vc, vm) = (a.to_array(), b.to_array(), c.to_array(), m.to_array());
            for i in 0..3 {
                for j in 0..3 {
                    second[i][j] += da / 12.0
                        * (va[i] * va[j] + vb[i] * vb[j] + vc[i] * vc[j] + 9.0 * vm[i] * vm[j]);
                }
            }
        }
        if area <= 0.0 {
            return SurfaceMoments {
                area,
                covariance: [[0.0; 3]; 3],
            };
        }
        let c = first * (1.0 / area);
        let ca = c.to_array();
        let mut covariance = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                covariance[i][j] = second[i][j] / area - ca[i] * ca[j];
            }
        }
        SurfaceMoments { area, covariance }
    }
}

trait ToArray {
    fn to_array(self) -> [f64; 3];
}

impl ToArray for Vec3 {
    fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// Checks that the mesh's axis of symmetry (the principal axis whose moment stands apart from the
/// other two: the longest, for a projectile) is x_B; returns the angle between them, deg.
fn check_axis(moments: &SurfaceMoments, warnings: &mut Vec<String>) -> Result<f64, MeshModelError> {
    let (values, vectors) = symmetric_eigen(moments.covariance);
    let apart = |i: usize| {
        (0..3)
            .filter(|&j| j != i)
            .map(|j| (values[i] - values[j]).abs())
            .fold(f64::INFINITY, f64::min)
    };
    let axis_index = (0..3)
        .max_by(|&a, &b| apart(a).total_cmp(&apart(b)))
        .expect("three eigenvalues");
    let largest = values.iter().copied().fold(0.0, f64::max);
    if apart(axis_index) < 0.05 * largest {
        warnings.push(
            "the mesh has no clear principal axis (about as long as wide); x_B taken as its axis"
                .to_string(),
        );
        return Ok(0.0);
    }
    let axis = [
        vectors[0][axis_index],
        vectors[1][axis_index],
        vectors[2][axis_index],
    ];
    let angle_deg = libm::acos(axis[0].abs().min(1.0)).to_degrees();
    if angle_deg > MAX_AXIS_TILT_DEG {
        let sign = if axis[0] < 0.0 { -1.0 } else { 1.0 };
        return Err(MeshModelError::NotAlongX {
            angle_deg,
            axis: axis.map(|c| c * sign),
        });
    }
    if angle_deg > 0.2 {
        warnings.push(format!(
            "the mesh's principal axis is {angle_deg:.2} deg off x_B"
        ));
    }
    Ok(angle_deg)
}

/// Eigenvalues and eigenvectors (the columns of the matrix) of a symmetric 3x3 matrix, by
/// cyclic Jacobi rotations.
fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale: f64 = a.iter().flatten().map(|x| x * x).sum();
    for _ in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if off <= 1e-30 * scale {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + libm::sqrt(theta * theta + 1.0));
            let c = 1.0 / libm::sqrt(t * t + 1.0);
            let s = t * c;
            for row in &mut a {
                let (kp, kq) = (row[p], row[q]);
                row[p] = c * kp - s * kq;
                row[q] = s * kp + c * kq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * row_p[k] - s * row_q[k]);
            a[q] = std::array::from_fn(|k| s * row_p[k] + c * row_q[k]);
            for row in &mut v {
                let (kp, kq) = (row[p], row[q]);
                row[p] = c * kp - s * kq;
                row[q] = s * kp + c * kq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// The largest radius of a cut's outline in each roll sector (0 where the outline does not
/// reach), m. Sector k covers roll angles [k, k + 1) * 360 / SECTORS deg, from +y_B towards +z_B.
type Sectors = [f64; SECTORS];

const SECTOR_WIDTH: f64 = 2.0 * PI / SECTORS as f64;

/// Roll angle of (y, z) in [0, 2 pi).
fn roll(p: [f64; 2]) -> f64 {
    let a = libm::atan2(p[1], p[0]);
    if a < 0.0 { a + 2.0 * PI } else { a }
}

fn sector_of(p: [f64; 2]) -> usize {
    ((roll(p) / SECTOR_WIDTH) as usize).min(SECTORS - 1)
}

/// The body radius of a cut: the 90 % quantile of the sectors outside the fins (the radius of a
/// faceted body's vertices: a 12-sided body has one in 6 sectors).
fn body_radius(cut: &Sectors, excluded: &[bool; SECTORS]) -> f64 {
    let mut r: Vec<f64> = cut
        .iter()
        .zip(excluded)
        .filter(|&(_, &x)| !x)
        .map(|(&r, _)| r)
        .collect();
    r.sort_unstable_by(f64::total_cmp);
    r[(r.len() - 1) * 9 / 10]
}

/// The offset (y, z) of a cut's outline from the axis: least squares on the difference of
/// opposite sectors, r(a) - r(a + 180 deg) = 2 offset . u(a), over the pairs outside the fins.
fn outline_offset(cut: &Sectors, excluded: &[bool; SECTORS]) -> Option<[f64; 2]> {
    let half = SECTORS / 2;
    let (mut a, mut b) = ([0.0; 3], [0.0; 2]);
    for k in 0..half {
        if excluded[k] || excluded[k + half] {
            continue;
        }
        let angle = (k as f64 + 0.5) * SECTOR_WIDTH;
        let u = [libm::cos(angle), libm::sin(angle)];
        let d = cut[k] - cut[k + half];
        a[0] += 2.0 * u[0] * u[0];
        a[1] += 2.0 * u[0] * u[1];
        a[2] += 2.0 * u[1] * u[1];
        b[0] += d * u[0];
        b[1] += d * u[1];
    }
    let det = a[0] * a[2] - a[1] * a[1];
    (det > 1.0).then(|| {
        [
            (a[2] * b[0] - a[1] * b[1]) / det,
            (a[0] * b[1] - a[1] * b[0]) / det,
        ]
    })
}

fn median(cut: &Sectors) -> f64 {
    let mut r = *cut;
    r.sort_unstable_by(f64::total_cmp);
    0.5 * (r[SECTORS / 2 - 1] + r[SECTORS / 2])
}

/// Cuts a mesh with planes across x_B.
struct Slicer {
    triangles: Vec<[[f64; 3]; 3]>,
    x_nose: f64,
    overall: f64,
    /// Distance between stations.
    h: f64,
    /// The triangles that reach between station i and i + 1 (indices into `triangles`).
    buckets: Vec<Vec<u32>>,
    /// Unit vectors (y, z) along the sector boundaries.
    rays: [[f64; 2]; SECTORS],
}

impl Slicer {
    fn new(mesh: &Mesh, x_nose: f64, overall: f64) -> Slicer {
        let triangles: Vec<[[f64; 3]; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.map(|i| {
                    let v = mesh.vertices[i as usize];
                    [v.x, v.y, v.z]
                })
            })
            .collect();
        let h = overall / (STATIONS - 1) as f64;
        let mut buckets = vec![Vec::new(); STATIONS - 1];
        for (n, t) in triangles.iter().enumerate() {
            let (first, last) = Self::intervals(t, x_nose, h);
            for bucket in &mut buckets[first..=last] {
                bucket.push(u32::try_from(n).expect("triangle count fits in u32"));
            }
        }
        let rays = std::array::from_fn(|k| {
            let a = k as f64 * SECTOR_WIDTH;
            [libm::cos(a), libm::sin(a)]
        });
        Slicer {
            triangles,
            x_nose,
            overall,
            h,
            buckets,
            rays,
        }
    }

    /// The first and last intervals between stations that a triangle reaches into.
    fn intervals(t: &[[f64; 3]; 3], x_nose: f64, h: f64) -> (usize, usize) {
        let hi = t[0][0].max(t[1][0]).max(t[2][0]);
        let lo = t[0][0].min(t[1][0]).min(t[2][0]);
        let index = |s: f64| ((s / h).floor().max(0.0) as usize).min(STATIONS - 2);
        (index(x_nose - hi), index(x_nose - lo))
    }

    /// s of the cut at `s`, kept just inside the mesh's ends.
    fn clamp(&self, s: f64) -> f64 {
        let d = END_OFFSET * self.overall;
        s.clamp(d, self.overall - d)
    }

    /// The cut at `s`.
    fn at(&self, s: f64) -> Sectors {
        let s = self.clamp(s);
        let x = self.x_nose - s;
        let interval = ((s / self.h) as usize).min(STATIONS - 2);
        let mut sectors = [0.0; SECTORS];
        for &n in &self.buckets[interval] {
            if let Some((p, q)) = cut(&self.triangles[n as usize], x) {
                accumulate(&mut sectors, p, q, &self.rays);
            }
        }
        sectors
    }

    /// The cuts at the stations s = i h, i in 0..STATIONS.
    fn sweep(&self) -> Vec<Sectors> {
        let mut cuts = vec![[0.0; SECTORS]; STATIONS];
        for t in &self.triangles {
            let (first, last) = Self::intervals(t, self.x_nose, self.h);
            for (i, sectors) in cuts.iter_mut().enumerate().take(last + 2).skip(first) {
                let x = self.x_nose - self.clamp(i as f64 * self.h);
                if let Some((p, q)) = cut(t, x) {
                    accumulate(sectors, p, q, &self.rays);
                }
            }
        }
        cuts
    }
}

/// The segment (y, z) where the plane x_B = `x` cuts a triangle (vertices on the plane count as
/// behind it, so faces in the plane are left out and their neighbours' edges kept).
fn cut(t: &[[f64; 3]; 3], x: f64) -> Option<([f64; 2], [f64; 2])> {
    let d = [t[0][0] - x, t[1][0] - x, t[2][0] - x];
    let ahead = d.map(|d| d > 0.0);
    let n = ahead.iter().filter(|&&a| a).count();
    if n == 0 || n == 3 {
        return None;
    }
    let mut points = [[0.0; 2]; 2];
    let mut found = 0;
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        if ahead[i] != ahead[j] {
            let f = d[i] / (d[i] - d[j]);
            points[found] = [
                t[i][1] + f * (t[j][1] - t[i][1]),
                t[i][2] + f * (t[j][2] - t[i][2]),
            ];
            found += 1;
        }
    }
    Some((points[0], points[1]))
}

fn raise(sectors: &mut Sectors, k: usize, r: f64) {
    if r > sectors[k] {
        sectors[k] = r;
    }
}

/// Raises each sector the segment p-q crosses to the segment's largest radius inside it (at an
/// end of the segment's piece in that sector, since the radius along a line is convex).
fn accumulate(sectors: &mut Sectors, p: [f64; 2], q: [f64; 2], rays: &[[f64; 2]; SECTORS]) {
    let (rp, rq) = (libm::hypot(p[0], p[1]), libm::hypot(q[0], q[1]));
    let (kp, kq) = (sector_of(p), sector_of(q));
    raise(sectors, kp, rp);
    raise(sectors, kq, rq);
    if kp == kq {
        return;
    }
    let d = [q[0] - p[0], q[1] - p[1]];
    let hit = |u: [f64; 2]| -> Option<f64> {
        let den = u[0] * d[1] - u[1] * d[0];
        if den == 0.0 {
            return None;
        }
        let t = (-(u[0] * p[1] - u[1] * p[0]) / den).clamp(0.0, 1.0);
        let x = [p[0] + t * d[0], p[1] + t * d[1]];
        (x[0] * u[0] + x[1] * u[1] >= 0.0).then(|| libm::hypot(x[0], x[1]))
    };
    let ccw = (kq + SECTORS - kp) % SECTORS;
    let boundaries: Vec<usize> = if p[0] * q[1] - p[1] * q[0] >= 0.0 {
        (1..=ccw).map(|j| (kp + j) % SECTORS).collect()
    } else {
        (0..SECTORS - ccw)
            .map(|j| (kp + SECTORS - j) % SECTORS)
            .collect()
    };
    for b in boundaries {
        if let Some(r) = hit(rays[b]) {
            raise(sectors, b, r);
            raise(sectors, (b + SECTORS - 1) % SECTORS, r);
        }
    }
}

/// Refines the boundary of `inside` between `a` (inside) and `b` (outside) by bisection: the
/// last point found inside.
fn boundary(mut a: f64, mut b: f64, inside: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..BISECTIONS {
        let m = 0.5 * (a + b);
        if inside(m) {
            a = m;
        } else {
            b = m;
        }
    }
    a
}

/// Douglas-Peucker on the radius between the forced points: the indices kept.
fn simplify(points: &[(f64, f64)], forced: &[usize], tolerance: f64) -> Vec<usize> {
    fn split(points: &[(f64, f64)], a: usize, b: usize, tolerance: f64, keep: &mut [bool]) {
        if b <= a + 1 {
            return;
        }
        let (sa, ra) = points[a];
        let (sb, rb) = points[b];
        let (worst, error) = (a + 1..b)
            .map(|i| {
                let (s, r) = points[i];
                let line = ra + (rb - ra) * (s - sa) / (sb - sa);
                (i, (r - line).abs())
            })
            .max_by(|x, y| x.1.total_cmp(&y.1))
            .expect("b > a + 1");
        if error > tolerance {
            keep[worst] = true;
            split(points, a, worst, tolerance, keep);
            split(points, worst, b, tolerance, keep);
        }
    }
    let mut keep = vec![false; points.len()];
    let mut anchors: Vec<usize> = forced.to_vec();
    anchors.sort_unstable();
    anchors.dedup();
    for &i in &anchors {
        keep[i] = true;
    }
    for w in anchors.windows(2) {
        split(points, w[0], w[1], tolerance, &mut keep);
    }
    (0..points.len()).filter(|&i| keep[i]).collect()
}

/// A run of fin sectors, one fin's roll range.
struct Cluster {
    /// The sectors that stand out.
    sectors: Vec<usize>,
    /// Those and one more on each side.
    wide: Vec<usize>,
}

impl Cluster {
    fn centre_deg(&self) -> f64 {
        let (sy, sz) = self.sectors.iter().fold((0.0, 0.0), |(y, z), &k| {
            let a = (k as f64 + 0.5) * SECTOR_WIDTH;
            (y + libm::cos(a), z + libm::sin(a))
        });
        roll([sy, sz]).to_degrees()
    }
}

/// The circular runs of `true` sectors.
fn circular_runs(flags: &[bool; SECTORS]) -> Vec<Cluster> {
    let Some(start) = flags.iter().position(|&f| !f) else {
        let all: Vec<usize> = (0..SECTORS).collect();
        return vec![Cluster {
            sectors: all.clone(),
            wide: all,
        }];
    };
    let mut runs: Vec<Vec<usize>> = Vec::new();
    let mut current: Vec<usize> = Vec::new();
    for j in 1..=SECTORS {
        let k = (start + j) % SECTORS;
        if flags[k] {
            current.push(k);
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    runs.into_iter()
        .map(|sectors| {
            let first = sectors[0];
            let last = sectors[sectors.len() - 1];
            let mut wide = vec![(first + SECTORS - 1) % SECTORS];
            wide.extend(&sectors);
            wide.push((last + 1) % SECTORS);
            wide.sort_unstable();
            wide.dedup();
            Cluster { sectors, wide }
        })
        .collect()
}

/// The stations where a fin stands out from the body.
struct Run {
    first: usize,
    last: usize,
    /// Integral of the excess over s, m^2.
    area: f64,
    /// Largest excess, m.
    height: f64,
}

/// One fin as measured.
struct Fin {
    roll_deg: f64,
    root_le_s: f64,
    root_te_s: f64,
    tip_le_s: f64,
    tip_te_s: f64,
    tip_radius_m: f64,
    thickness_m: f64,
}

/// What the fin measurements need.
struct FinContext<'a> {
    mesh: &'a Mesh,
    used: &'a [bool],
    slicer: &'a Slicer,
    cuts: &'a [Sectors],
    radii: &'a [f64],
    excluded: &'a [bool; SECTORS],
    h: f64,
    x_nose: f64,
    overall: f64,
    length: f64,
    fin_excess: f64,
    body_at: &'a dyn Fn(f64) -> f64,
}

impl FinContext<'_> {
    /// How far a cluster's sectors stand out from the body radius `body` in a cut.
    fn excess(cut: &Sectors, body: f64, wide: &[usize]) -> f64 {
        wide.iter().map(|&k| cut[k]).fold(0.0, f64::max) - body
    }

    /// How far a cluster's sectors stand out from the body at `s`, and the body radius there.
    fn excess_at(&self, s: f64, wide: &[usize]) -> (f64, f64) {
        let cut = self.slicer.at(s);
        let body = body_radius(&cut, self.excluded);
        (Self::excess(&cut, body, wide), body)
    }

    /// The stations where the cluster stands out the most (other runs are reported).
    fn main_run(&self, cluster: &Cluster, warnings: &mut Vec<String>) -> Option<Run> {
        let mut runs: Vec<Run> = Vec::new();
        for (i, (cut, &body)) in self.cuts.iter().zip(self.radii).enumerate() {
            let e = Self::excess(cut, body, &cluster.wide);
            if e <= self.fin_excess {
                continue;
            }
            match runs.last_mut() {
                Some(run) if run.last + 1 == i => {
                    run.last = i;
                    run.area += e * self.h;
                    run.height = run.height.max(e);
                }
                _ => runs.push(Run {
                    first: i,
                    last: i,
                    area: e * self.h,
                    height: e,
                }),
            }
        }
        let main = runs
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.area.total_cmp(&b.1.area))
            .map(|(i, _)| i)?;
        for (i, run) in runs.iter().enumerate() {
            if i != main {
                warnings.push(format!(
                    "ignored a second fin-like part at roll {:.0} deg, {:.1} .. {:.1} mm aft of the tip: the model has one set of fins",
                    cluster.centre_deg(),
                    run.first as f64 * self.h * 1e3,
                    run.last as f64 * self.h * 1e3
                ));
            }
        }
        Some(runs.swap_remove(main))
    }

    /// Measures the fin of a cluster; None if no vertex stands out there.
    fn fin(&self, cluster: &Cluster, run: &Run) -> Option<Fin> {
        let s_lo = (run.first as f64 - 1.0) * self.h;
        let s_hi = (run.last as f64 + 1.0) * self.h;
        let points: Vec<(f64, [f64; 2])> = self
            .mesh
            .vertices
            .iter()
            .zip(self.used)
            .filter(|&(_, &u)| u)
            .filter_map(|(v, _)| {
                let s = self.x_nose - v.x;
                let p = [v.y, v.z];
                let inside = (s_lo..=s_hi).contains(&s)
                    && cluster.wide.contains(&sector_of(p))
                    && libm::hypot(p[0], p[1]) - (self.body_at)(s) > self.fin_excess;
                inside.then_some((s, p))
            })
            .collect();
        if points.is_empty() {
            return None;
        }
        // The fin's plane: through the mean of its vertices (a symmetric fin's faces balance).
        let (sy, sz) = points
            .iter()
            .fold((0.0, 0.0), |(y, z), (_, p)| (y + p[0], z + p[1]));
        let phi = roll([sy, sz]);
        let out = [libm::cos(phi), libm::sin(phi)];
        let across = [-out[1], out[0]];
        let radial = |p: &[f64; 2]| p[0] * out[0] + p[1] * out[1];
        let lateral = |p: &[f64; 2]| p[0] * across[0] + p[1] * across[1];
        let tip_radius = points
            .iter()
            .map(|(_, p)| radial(p))
            .fold(f64::NEG_INFINITY, f64::max);
        let (tip_le, tip_te) = points
            .iter()
            .filter(|(_, p)| radial(p) >= tip_radius * (1.0 - TIP_TOLERANCE))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (s, _)| {
                (lo.min(*s), hi.max(*s))
            });
        let (side_lo, side_hi) = points
            .iter()
            .map(|(_, p)| lateral(p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });

        // Where the fin leaves the body, extended along its edges down to the body.
        let stands_out = |s: f64| self.excess_at(s, &cluster.wide).0 > self.fin_excess;
        let at = |i: usize| i as f64 * self.h;
        let root_le = if run.first == 0 {
            0.0
        } else {
            let s = boundary(at(run.first), at(run.first - 1), stands_out);
            let body = self.excess_at(s, &cluster.wide).1;
            let rise = tip_radius - body - self.fin_excess;
            if tip_le > s && rise > 0.0 {
                s - self.fin_excess * (tip_le - s) / rise
            } else {
                s.min(tip_le)
            }
        };
        let root_te = if run.last == STATIONS - 1 {
            self.overall
        } else {
            let s = boundary(at(run.last), at(run.last + 1), stands_out);
            let body = self.excess_at(s, &cluster.wide).1;
            let fall = tip_radius - body - self.fin_excess;
            if tip_te < s && fall > 0.0 {
                s + self.fin_excess * (s - tip_te) / fall
            } else {
                s.max(tip_te)
            }
        };
        let roll_deg = phi.to_degrees();
        Some(Fin {
            roll_deg: if roll_deg > 360.0 - 1e-9 {
                0.0
            } else {
                roll_deg
            },
            root_le_s: root_le.max(0.0),
            root_te_s: root_te.min(self.length),
            tip_le_s: tip_le,
            tip_te_s: tip_te,
            tip_radius_m: tip_radius,
            thickness_m: side_hi - side_lo,
        })
    }
}

/// The planform of fins measured one by one, checking that they are evenly spaced, and their
/// roll angles (ascending).
fn combine_fins(
    fins: &mut [Fin],
    warnings: &mut Vec<String>,
) -> Result<(FinPlanform, Vec<f64>), MeshModelError> {
    fins.sort_by(|a, b| a.roll_deg.total_cmp(&b.roll_deg));
    let rolls: Vec<f64> = fins.iter().map(|f| f.roll_deg).collect();
    let n = fins.len();
    if n < 2 {
        return Err(MeshModelError::UnevenFins { roll_deg: rolls });
    }
    let spacing = 360.0 / n as f64;
    // Circular mean of n * roll, which even spacing makes the same for every fin.
    let (sy, sz) = rolls.iter().fold((0.0, 0.0), |(y, z), a| {
        let b = (n as f64 * a).to_radians();
        (y + libm::cos(b), z + libm::sin(b))
    });
    let mut first = roll([sy, sz]).to_degrees() / n as f64;
    if first > spacing - 1e-9 {
        first = 0.0;
    }
    let uneven = rolls.iter().any(|a| {
        let d = (a - first) / spacing;
        (d - d.round()).abs() * spacing > FIN_SPACING_TOLERANCE_DEG
    });
    let mut positions: Vec<i64> = rolls
        .iter()
        .map(|a| (((a - first) / spacing).round() as i64).rem_euclid(n as i64))
        .collect();
    positions.sort_unstable();
    positions.dedup();
    if uneven || positions.len() != n {
        return Err(MeshModelError::UnevenFins { roll_deg: rolls });
    }
    let mean = |f: &dyn Fn(&Fin) -> f64| fins.iter().map(f).sum::<f64>() / n as f64;
    let planform = FinPlanform {
        count: u32::try_from(n).expect("fewer fins than sectors"),
        root_le_s: mean(&|f| f.root_le_s),
        root_te_s: mean(&|f| f.root_te_s),
        tip_le_s: mean(&|f| f.tip_le_s),
        tip_te_s: mean(&|f| f.tip_te_s),
        tip_radius_m: mean(&|f| f.tip_radius_m),
        thickness_m: mean(&|f| f.thickness_m),
        first_fin_roll_deg: first,
    };
    let differs = fins.iter().any(|f| {
        [
            (f.root_le_s, planform.root_le_s),
            (f.root_te_s, planform.root_te_s),
            (f.tip_le_s, planform.tip_le_s),
            (f.tip_te_s, planform.tip_te_s),
            (f.tip_radius_m, planform.tip_radius_m),
            (f.thickness_m, planform.thickness_m),
        ]
        .iter()
        .any(|(a, b)| (a - b).abs() > FIN_MISMATCH_M)
    });
    if differs {
        warnings.push(format!(
            "the fins differ by more than {:.1} mm; the model takes their mean",
            FIN_MISMATCH_M * 1e3
        ));
    }
    Ok((planform, rolls))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::math::{Mat3, rad};
    use crate::sim::model::{FinnedOgive, REF_1378X80};
    use std::time::Instant;

    /// A closed body of revolution through the (s, radius) stations, origin mid-length; a zero
    /// radius is an apex, a non-zero radius at an end a flat cap.
    fn revolve(stations: &[(f64, f64)], segments: usize) -> Mesh {
        let length = stations.last().unwrap().0;
        let mut mesh = Mesh::default();
        let ring_at = |mesh: &mut Mesh, s: f64, r: f64| -> Vec<u32> {
            let x = 0.5 * length - s;
            if r == 0.0 {
                return vec![mesh.push_vertex(Vec3::new(x, 0.0, 0.0))];
            }
            (0..segments)
                .map(|k| {
                    let a = 2.0 * PI * k as f64 / segments as f64;
                    mesh.push_vertex(Vec3::new(x, r * libm::cos(a), r * libm::sin(a)))
                })
                .collect()
        };
        let join = |mesh: &mut Mesh, a: &[u32], b: &[u32]| match (a.len(), b.len()) {
            (1, 1) => panic!("two apexes in a row"),
            (1, n) => (0..n).for_each(|k| mesh.triangles.push([a[0], b[k], b[(k + 1) % n]])),
            (n, 1) => (0..n).for_each(|k| mesh.triangles.push([a[(k + 1) % n], a[k], b[0]])),
            (n, _) => {
                (0..n).for_each(|k| mesh.push_quad(a[k], b[k], b[(k + 1) % n], a[(k + 1) % n]))
            }
        };
        let mut previous: Option<Vec<u32>> = None;
        for &(s, r) in stations {
            let ring = ring_at(&mut mesh, s, r);
            match &previous {
                None if ring.len() > 1 => {
                    let centre = ring_at(&mut mesh, s, 0.0);
                    join(&mut mesh, &centre, &ring);
                }
                None => {}
                Some(prev) => join(&mut mesh, prev, &ring),
            }
            previous = Some(ring);
        }
        let last = previous.unwrap();
        if last.len() > 1 {
            let centre = ring_at(&mut mesh, length, 0.0);
            join(&mut mesh, &last, &centre);
        }
        mesh
    }

    /// The profile's radius at `s`.
    fn radius_at(profile: &[(f64, f64)], s: f64) -> f64 {
        let i = profile
            .partition_point(|p| p.0 <= s)
            .clamp(1, profile.len() - 1);
        let ((s0, r0), (s1, r1)) = (profile[i - 1], profile[i]);
        r0 + (r1 - r0) * (s - s0) / (s1 - s0)
    }

    fn check_profile(model: &DerivedModel) {
        let p = &model.profile;
        assert!(p.len() <= MAX_PROFILE_STATIONS, "{} stations", p.len());
        assert_eq!(p[0].0, 0.0);
        assert_eq!(p[p.len() - 1].0, model.length_m);
        assert!(p.windows(2).all(|w| w[1].0 > w[0].0), "s increasing");
        assert!(p.iter().all(|&(_, r)| r >= 0.0));
    }

    fn derive_and_show(
        name: &str,
        mesh: &Mesh,
        diameter: Option<f64>,
    ) -> (DerivedModel, MeshReport) {
        let start = Instant::now();
        let (model, report) = derive(mesh, diameter).unwrap();
        let elapsed = start.elapsed();
        println!(
            "--- {name}: derived in {:.1} ms\n{report}{model:?}\n",
            elapsed.as_secs_f64() * 1e3
        );
        check_profile(&model);
        (model, report)
    }

    fn mm(m: f64) -> f64 {
        m * 1e3
    }

    #[test]
    fn mesh_model_of_the_reference_projectile() {
        let m = REF_1378X80;
        let mesh = m.tessellate();
        let start = Instant::now();
        derive(&mesh, Some(0.080)).unwrap();
        let elapsed = start.elapsed().as_secs_f64();
        println!(
            "reference mesh ({} triangles) derived in {:.1} ms",
            mesh.triangles.len(),
            elapsed * 1e3
        );
        if !cfg!(debug_assertions) {
            assert!(elapsed < 0.5, "{elapsed} s");
        }
        let (model, report) = derive_and_show("ref-1378x80", &mesh, Some(0.0805));
        assert!(
            (model.length_m - m.length).abs() < 1e-4,
            "{}",
            model.length_m
        );
        assert!(
            (model.diameter_m - 0.080).abs() < 0.002 * 0.080,
            "{}",
            model.diameter_m
        );
        let r = radius_at(&model.profile, 0.12);
        println!(
            "radius at s = 120 mm: {:.3} mm (ogive {:.3} mm)",
            mm(r),
            mm(m.radius_at(0.12))
        );
        assert!((r - m.radius_at(0.12)).abs() < 0.5e-3);
        for i in 0..=100 {
            let s = 0.24 + (m.length - 0.24) * f64::from(i) / 100.0;
            let r = radius_at(&model.profile, s);
            assert!((r - m.radius).abs() < 0.1e-3, "radius {r} at s = {s}");
        }
        assert!(model.profile[0].1 == 0.0, "pointed nose");
        assert!(report.boat_tail_start_m.is_none());
        let fins = model.fins.as_ref().expect("fins");
        assert_eq!(fins.count, 4);
        let close = |a: f64, b: f64| (a - b).abs() < 2e-3;
        assert!(close(fins.root_te_s - fins.root_le_s, 0.120), "{fins:?}");
        assert!(close(fins.tip_te_s - fins.tip_le_s, 0.060), "{fins:?}");
        assert!(close(fins.tip_radius_m, 0.100), "{fins:?}");
        assert!(close(fins.thickness_m, 0.004), "{fins:?}");
        assert!(
            close(fins.root_te_s, m.length) && close(fins.tip_te_s, m.length),
            "{fins:?}"
        );
        assert!(fins.first_fin_roll_deg.abs() < 0.5, "{fins:?}");
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);

        // The same mesh as a triangle soup (as STL files come): welded, the same answer.
        let soup = Mesh {
            vertices: mesh
                .triangles
                .iter()
                .flat_map(|t| t.map(|i| mesh.vertices[i as usize]))
                .collect(),
            triangles: (0..mesh.triangles.len() as u32)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect(),
        };
        assert_eq!(derive(&soup, None).unwrap().0, model);
    }

    #[test]
    fn mesh_model_of_a_boat_tailed_shell() {
        // 600 mm x 100 mm: a 180 mm tangent ogive, a cylinder, a 60 mm boat tail to 80 mm.
        let ogive = FinnedOgive {
            length: 0.6,
            radius: 0.05,
            nose_length: 0.18,
            fin_count: 0,
            ..REF_1378X80
        };
        let mut stations: Vec<(f64, f64)> = (0..=40)
            .map(|i| {
                let f = f64::from(i) / 40.0;
                let s = 0.18 * f * libm::sqrt(f);
                (s, ogive.radius_at(s))
            })
            .collect();
        stations.extend([(0.54, 0.05), (0.6, 0.04)]);
        for segments in [64, 16] {
            let mesh = revolve(&stations, segments);
            let (model, report) = derive_and_show(
                &format!("boat-tailed shell, {segments} segments"),
                &mesh,
                Some(0.1),
            );
            assert!(model.fins.is_none());
            assert!((model.length_m - 0.6).abs() < 1e-4);
            assert!(
                (model.diameter_m - 0.1).abs() < 0.002 * 0.1,
                "{}",
                model.diameter_m
            );
            let base = model.profile.last().unwrap().1;
            assert!((base - 0.04).abs() < 0.1e-3, "base radius {base}");
            assert!((radius_at(&model.profile, 0.57) - 0.045).abs() < 0.2e-3);
            let start = report.boat_tail_start_m.expect("a boat tail");
            assert!((start - 0.54).abs() < 4e-3, "{start}");
            assert_eq!(model.profile[0].1, 0.0);
            let r = radius_at(&model.profile, 0.09);
            assert!((r - ogive.radius_at(0.09)).abs() < 0.5e-3, "{r}");
        }
    }

    #[test]
    fn mesh_model_of_a_large_mesh() {
        // The reference body (no fins) with 720 segments and 300 nose stations: 435k triangles.
        let m = REF_1378X80;
        let mut stations: Vec<(f64, f64)> = (0..=300)
            .map(|i| {
                let s = m.nose_length * f64::from(i) / 300.0;
                (s, m.radius_at(s))
            })
            .collect();
        stations.push((m.length, m.radius));
        let mesh = revolve(&stations, 720);
        let start = Instant::now();
        let (model, _) = derive(&mesh, None).unwrap();
        let elapsed = start.elapsed().as_secs_f64();
        println!(
            "{} triangles derived in {:.1} ms",
            mesh.triangles.len(),
            elapsed * 1e3
        );
        assert!((model.diameter_m - 0.08).abs() < 1e-6);
        if !cfg!(debug_assertions) {
            assert!(elapsed < 2.0, "{elapsed} s");
        }
    }

    /// A consistently outward mesh draws no warning about its facing; one triangle turned over
    /// is reported as the three edges it shares wound the same way as its neighbours, and every
    /// triangle turned over as a surface facing inwards.
    #[test]
    fn a_mesh_wound_inconsistently_or_inwards_is_reported() {
        let mesh = revolve(&[(0.0, 0.01), (0.15, 0.05), (0.5, 0.05)], 48);
        let facing = |mesh: &Mesh| {
            let (_, report) = derive(mesh, None).unwrap();
            report
                .warnings
                .into_iter()
                .filter(|w| w.contains("wound"))
                .collect::<Vec<_>>()
        };
        assert!(facing(&mesh).is_empty(), "{:?}", facing(&mesh));
        let mut one = mesh.clone();
        one.triangles[7].swap(1, 2);
        let warnings = facing(&one);
        assert!(
            warnings.len() == 1
                && warnings[0].starts_with("3 edge(s) join triangles wound the same way"),
            "{warnings:?}"
        );
        let mut all = mesh;
        all.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        let warnings = facing(&all);
        assert!(
            warnings.len() == 1 && warnings[0].contains("facing inwards"),
            "{warnings:?}"
        );
    }

    #[test]
    fn mesh_model_of_a_blunt_nose() {
        // A 20 mm flat tip, a cone to 100 mm at 150 mm, a cylinder to 500 mm.
        let mesh = revolve(&[(0.0, 0.01), (0.15, 0.05), (0.5, 0.05)], 48);
        let (model, report) = derive_and_show("blunt cone-cylinder", &mesh, None);
        assert!(
            (model.profile[0].1 - 0.01).abs() < 0.1e-3,
            "{:?}",
            model.profile[0]
        );
        assert!((report.nose_flat_diameter_m - 0.02).abs() < 0.2e-3);
        assert!((report.nose_length_m - 0.15).abs() < 3e-3);
        assert!((radius_at(&model.profile, 0.075) - 0.03).abs() < 0.1e-3);
        assert!(model.fins.is_none() && report.boat_tail_start_m.is_none());
    }

    #[test]
    fn mesh_model_of_six_fins() {
        let six = FinnedOgive {
            fin_count: 6,
            ..REF_1378X80
        };
        let (model, _) = derive_and_show("six fins", &six.tessellate(), None);
        let fins = model.fins.expect("fins");
        assert_eq!(fins.count, 6);
        assert!((fins.first_fin_roll_deg - 30.0).abs() < 0.5, "{fins:?}");
        assert!(
            (fins.root_te_s - fins.root_le_s - 0.12).abs() < 2e-3,
            "{fins:?}"
        );
        assert!((fins.tip_radius_m - 0.1).abs() < 2e-3, "{fins:?}");
    }

    #[test]
    fn mesh_model_of_fins_beyond_the_base() {
        // The reference with its fins moved 20 mm aft: they overhang the base.
        let body_vertices = FinnedOgive {
            fin_count: 0,
            ..REF_1378X80
        }
        .tessellate()
        .vertices
        .len();
        let mut mesh = REF_1378X80.tessellate();
        for v in &mut mesh.vertices[body_vertices..] {
            v.x -= 0.02;
        }
        let (model, report) = derive_and_show("fins 20 mm beyond the base", &mesh, None);
        assert!((model.length_m - 1.378).abs() < 1e-4, "{}", model.length_m);
        assert!((report.overall_length_m - 1.398).abs() < 1e-6);
        let fins = model.fins.expect("fins");
        assert_eq!(fins.count, 4);
        assert!((fins.root_le_s - 1.278).abs() < 2e-3, "{fins:?}");
        assert!((fins.root_te_s - 1.378).abs() < 2e-3, "{fins:?}");
        assert!((fins.tip_le_s - 1.338).abs() < 2e-3, "{fins:?}");
        assert!((fins.tip_te_s - 1.398).abs() < 2e-3, "{fins:?}");
        assert!((model.profile.last().unwrap().1 - 0.04).abs() < 0.1e-3);
        assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    }

    /// A body with four rectangular fins fused to it (one surface, as a CAD union exports):
    /// a 200 mm tangent ogive, 80 mm across, 1 m long; fins 5 mm thick from 900 mm to the base,
    /// 90 mm from the axis, at roll 45, 135, 225 and 315 deg.
    fn fused_fins() -> Mesh {
        let (length, radius, fin_start, tip_r, t) = (1.0, 0.04, 0.9, 0.09, 0.005);
        let ogive = FinnedOgive {
            length,
            radius,
            nose_length: 0.2,
            fin_count: 0,
            ..REF_1378X80
        };
        let n = 64;
        let fins_at = [8, 24, 40, 56];
        let delta = libm::asin(0.5 * t / radius);
        // The outline ahead of the fins: a circle with three points at each fin (its root's
        // sides and its middle).
        let mut angles = Vec::new();
        let mut middles = Vec::new();
        for k in 0..n {
            let a = 2.0 * PI * f64::from(k) / f64::from(n);
            if fins_at.contains(&k) {
                middles.push(angles.len() + 1);
                angles.extend([a - delta, a, a + delta]);
            } else {
                angles.push(a);
            }
        }
        let x = |s: f64| 0.5 * length - s;
        let mut mesh = Mesh::default();
        let ring = |mesh: &mut Mesh, s: f64| -> Vec<u32> {
            let r = ogive.radius_at(s);
            angles
                .iter()
                .map(|&a| mesh.push_vertex(Vec3::new(x(s), r * libm::cos(a), r * libm::sin(a))))
                .collect()
        };
        let stitch = |mesh: &mut Mesh, a: &[u32], b: &[u32]| {
            let n = a.len();
            for k in 0..n {
                mesh.push_quad(a[k], b[k], b[(k + 1) % n], a[(k + 1) % n]);
            }
        };
        let apex = mesh.push_vertex(Vec3::new(x(0.0), 0.0, 0.0));
        let mut previous: Vec<u32> = Vec::new();
        for i in 1..=30 {
            let f = f64::from(i) / 30.0;
            let current = ring(&mut mesh, 0.2 * f * libm::sqrt(f));
            if previous.is_empty() {
                let m = current.len();
                for k in 0..m {
                    mesh.triangles
                        .push([apex, current[k], current[(k + 1) % m]]);
                }
            } else {
                stitch(&mut mesh, &previous, &current);
            }
            previous = current;
        }
        let plain = ring(&mut mesh, fin_start);
        stitch(&mut mesh, &previous, &plain);
        // The finned outline: each fin's middle point replaced by its tip's two corners, the
        // fin's front face closing the gap.
        let mut finned = Vec::new();
        for (j, &index) in plain.iter().enumerate() {
            if !middles.contains(&j) {
                finned.push(index);
                continue;
            }
            let a = angles[j];
            let out = Vec3::new(0.0, libm::cos(a), libm::sin(a));
            let across = Vec3::new(0.0, -libm::sin(a), libm::cos(a));
            let centre = Vec3::new(x(fin_start), 0.0, 0.0) + out * tip_r;
            let minus = mesh.push_vertex(centre - across * (0.5 * t));
            let plus = mesh.push_vertex(centre + across * (0.5 * t));
            mesh.triangles.push([index, plain[j - 1], minus]);
            mesh.triangles.push([index, minus, plus]);
            mesh.triangles.push([index, plus, plain[j + 1]]);
            finned.extend([minus, plus]);
        }
        let base: Vec<u32> = finned
            .iter()
            .map(|&i| {
                let v = mesh.vertices[i as usize];
                mesh.push_vertex(Vec3::new(x(length), v.y, v.z))
            })
            .collect();
        stitch(&mut mesh, &finned, &base);
        let centre = mesh.push_vertex(Vec3::new(x(length), 0.0, 0.0));
        let m = base.len();
        for k in 0..m {
            mesh.triangles.push([centre, base[(k + 1) % m], base[k]]);
        }
        mesh
    }

    #[test]
    fn mesh_model_of_fused_fins() {
        let (model, report) = derive_and_show("fused rectangular fins", &fused_fins(), Some(0.08));
        assert!((model.length_m - 1.0).abs() < 1e-9);
        assert!(
            (model.diameter_m - 0.08).abs() < 0.002 * 0.08,
            "{}",
            model.diameter_m
        );
        let fins = model.fins.expect("fins");
        assert_eq!(fins.count, 4);
        let close = |a: f64, b: f64| (a - b).abs() < 0.5e-3;
        assert!(
            close(fins.root_le_s, 0.9) && close(fins.tip_le_s, 0.9),
            "{fins:?}"
        );
        assert!(
            close(fins.root_te_s, 1.0) && close(fins.tip_te_s, 1.0),
            "{fins:?}"
        );
        assert!(close(fins.tip_radius_m, 0.09), "{fins:?}");
        assert!(close(fins.thickness_m, 0.005), "{fins:?}");
        assert!((fins.first_fin_roll_deg - 45.0).abs() < 0.1, "{fins:?}");
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    }

    #[test]
    fn mesh_model_errors() {
        let reference = REF_1378X80.tessellate();
        let show = |name: &str, mesh: &Mesh, diameter: Option<f64>| -> MeshModelError {
            let e = derive(mesh, diameter).unwrap_err();
            println!("{name}: {e}");
            e
        };
        assert_eq!(show("empty", &Mesh::default(), None), MeshModelError::Empty);

        let mut open = reference.clone();
        open.triangles.remove(1000);
        assert!(matches!(
            show("open", &open, None),
            MeshModelError::NotClosed { open_edges: 3, .. }
        ));

        let turn = Mat3::rot_z(rad(30.0));
        let rotated = Mesh {
            vertices: reference.vertices.iter().map(|&v| turn * v).collect(),
            triangles: reference.triangles.clone(),
        };
        match show("rotated", &rotated, None) {
            MeshModelError::NotAlongX { angle_deg, .. } => {
                assert!((angle_deg - 30.0).abs() < 0.5, "{angle_deg}")
            }
            e => panic!("{e:?}"),
        }

        let huge = Mesh {
            vertices: reference.vertices.iter().map(|&v| v * 1000.0).collect(),
            triangles: reference.triangles.clone(),
        };
        assert!(matches!(
            show("scaled 1000 x", &huge, None),
            MeshModelError::AbsurdSize { length_m } if (length_m - 1378.0).abs() < 1e-6
        ));

        let squashed = Mesh {
            vertices: reference
                .vertices
                .iter()
                .map(|v| Vec3::new(v.x, 0.85 * v.y, v.z))
                .collect(),
            triangles: reference.triangles.clone(),
        };
        assert!(matches!(
            show("squashed in y", &squashed, None),
            MeshModelError::NotAxisymmetric { spread_m, .. } if spread_m > 0.004
        ));

        let shifted = Mesh {
            vertices: reference
                .vertices
                .iter()
                .map(|&v| v + Vec3::new(0.0, 0.005, 0.0))
                .collect(),
            triangles: reference.triangles.clone(),
        };
        assert!(matches!(
            show("5 mm off axis", &shifted, None),
            MeshModelError::OffAxis { .. }
        ));

        assert_eq!(
            show("diameter 10 % off", &reference, Some(0.088)),
            MeshModelError::DiameterMismatch {
                given: 0.088,
                derived: derive(&reference, None).unwrap().0.diameter_m
            }
        );

        // Three of the four fins.
        let fin_triangles = 12;
        let mut three = reference.clone();
        three
            .triangles
            .truncate(reference.triangles.len() - fin_triangles);
        assert!(matches!(
            show("three fins of four", &three, None),
            MeshModelError::UnevenFins { roll_deg } if roll_deg.len() == 3
        ));
    }
}
