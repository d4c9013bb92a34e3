//! The projectile models the simulator can fly: the analytic reference projectile `ref-1378x80`
//! of `docs/projectile.md`, tessellated here, or any mesh file.
//!
//! Body frame B: origin at the middle of the overall length, +x_B along the axis towards the nose;
//! the fins point along +z_B, +y_B, -z_B, -y_B. s is the distance aft of the nose tip.

use super::math::Vec3;
use super::mesh::Mesh;
use super::scenario::ProjectileConfig;
use anyhow::{Context, bail};

/// Id of the built-in reference projectile.
pub const REFERENCE_ID: &str = "ref-1378x80";

/// Segments around the axis of the tessellated body of revolution.
const SEGMENTS: usize = 96;
/// Stations along the ogive nose (tip excluded).
const NOSE_STATIONS: usize = 48;
/// Aft share of a mesh's length left out when measuring its body radius (where fins are).
const FIN_ZONE: f64 = 0.2;

/// A finned body of revolution with a sharp tangent-ogive nose, a cylinder and a flat base, and
/// identical flat trapezoid fins whose trailing edges are flush with the base. Lengths in m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinnedOgive {
    /// Nose tip to base.
    pub length: f64,
    /// Body radius R.
    pub radius: f64,
    /// Ogive length Ln.
    pub nose_length: f64,
    /// Number of fins, evenly spaced in roll starting at +z_B and turning towards +y_B.
    pub fin_count: u32,
    /// Distance of the fin tip from the axis.
    pub fin_tip_radius: f64,
    /// Fin chord at the body surface.
    pub fin_root_chord: f64,
    /// Fin chord at the tip.
    pub fin_tip_chord: f64,
    /// Fin thickness.
    pub fin_thickness: f64,
}

/// The reference projectile `ref-1378x80` (`docs/projectile.md`).
pub const REF_1378X80: FinnedOgive = FinnedOgive {
    length: 1.378,
    radius: 0.040,
    nose_length: 0.240,
    fin_count: 4,
    fin_tip_radius: 0.100,
    fin_root_chord: 0.120,
    fin_tip_chord: 0.060,
    fin_thickness: 0.004,
};

impl FinnedOgive {
    /// Radius of the ogive's generating arc, rho = (R^2 + Ln^2) / (2 R).
    pub fn ogive_rho(&self) -> f64 {
        (self.radius * self.radius + self.nose_length * self.nose_length) / (2.0 * self.radius)
    }

    /// Body radius (without fins) at distance `s` aft of the nose tip, m.
    pub fn radius_at(&self, s: f64) -> f64 {
        if s >= self.nose_length {
            return self.radius;
        }
        let rho = self.ogive_rho();
        let d = self.nose_length - s;
        (libm::sqrt(rho * rho - d * d) + self.radius - rho).max(0.0)
    }

    /// x_B of the point `s` aft of the nose tip.
    fn x_at(&self, s: f64) -> f64 {
        0.5 * self.length - s
    }

    /// A closed triangle mesh of the body and fins.
    pub fn tessellate(&self) -> Mesh {
        let mut mesh = Mesh::default();
        let ring = |mesh: &mut Mesh, s: f64| -> Vec<u32> {
            let r = self.radius_at(s);
            (0..SEGMENTS)
                .map(|k| {
                    let a = 2.0 * std::f64::consts::PI * k as f64 / SEGMENTS as f64;
                    mesh.push_vertex(Vec3::new(self.x_at(s), r * libm::sin(a), r * libm::cos(a)))
                })
                .collect()
        };
        // Nose: apex fan, then rings clustered towards the tip where the curvature is.
        let apex = mesh.push_vertex(Vec3::new(self.x_at(0.0), 0.0, 0.0));
        let mut previous: Option<Vec<u32>> = None;
        for i in 1..=NOSE_STATIONS {
            let f = i as f64 / NOSE_STATIONS as f64;
            let current = ring(&mut mesh, self.nose_length * f * libm::sqrt(f));
            match &previous {
                None => {
                    for k in 0..SEGMENTS {
                        mesh.triangles
                            .push([apex, current[(k + 1) % SEGMENTS], current[k]]);
                    }
                }
                Some(prev) => stitch(&mut mesh, prev, &current),
            }
            previous = Some(current);
        }
        // Cylinder to the base, and the flat base.
        let base_ring = ring(&mut mesh, self.length);
        if let Some(prev) = &previous {
            stitch(&mut mesh, prev, &base_ring);
        }
        let centre = mesh.push_vertex(Vec3::new(self.x_at(self.length), 0.0, 0.0));
        for k in 0..SEGMENTS {
            mesh.triangles
                .push([centre, base_ring[k], base_ring[(k + 1) % SEGMENTS]]);
        }
        for fin in 0..self.fin_count {
            self.push_fin(&mut mesh, fin);
        }
        mesh
    }

    /// One fin as a closed prism. Its root extends inside the body (hidden there) so it meets
    /// the round surface without a gap.
    fn push_fin(&self, mesh: &mut Mesh, index: u32) {
        let angle = 2.0 * std::f64::consts::PI * f64::from(index) / f64::from(self.fin_count);
        let out = Vec3::new(0.0, libm::sin(angle), libm::cos(angle));
        let (root_r, tip_r) = (0.5 * self.radius, self.fin_tip_radius);
        // The leading edge is the straight line through the root and tip chord ends.
        let le_root = self.length - self.fin_root_chord;
        let le_tip = self.length - self.fin_tip_chord;
        let slope = (le_tip - le_root) / (tip_r - self.radius);
        let outline = [
            (le_root + slope * (root_r - self.radius), root_r),
            (le_tip, tip_r),
            (self.length, tip_r),
            (self.length, root_r),
        ];
        super::shapes::push_plate(mesh, self.length, &outline, out, self.fin_thickness);
    }
}

/// Joins two rings of equal size with quads.
fn stitch(mesh: &mut Mesh, front: &[u32], back: &[u32]) {
    let n = front.len();
    for k in 0..n {
        let k1 = (k + 1) % n;
        mesh.push_quad(front[k], front[k1], back[k1], back[k]);
    }
}

/// The model that flies in a clip: its mesh and what the plume needs to know about it.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectileModel {
    /// Id written to `clip.json`.
    pub id: String,
    /// The mesh in B, m.
    pub mesh: Mesh,
    /// x_B of the base (the smallest x_B of the mesh), m.
    pub tail_x: f64,
    /// Body radius, m (for a mesh file: the largest distance of a vertex from the x_B axis over
    /// the front 80 % of the length, which leaves out tail fins).
    pub body_radius: f64,
}

impl ProjectileModel {
    /// The model a scenario asks for.
    pub fn from_config(cfg: &ProjectileConfig) -> anyhow::Result<ProjectileModel> {
        if let Some(path) = &cfg.mesh {
            let mesh = Mesh::load(path, cfg.mesh_scale)?;
            let id = path
                .file_stem()
                .and_then(|s| s.to_str())
                .context("the mesh file name is not valid UTF-8")?
                .to_string();
            return Ok(ProjectileModel::from_mesh(id, mesh));
        }
        if let Some(description) = super::shapes::description(&cfg.model) {
            return Ok(ProjectileModel::from_mesh(
                cfg.model.clone(),
                super::shapes::tessellate(&description),
            ));
        }
        if cfg.model != REFERENCE_ID {
            bail!(
                "projectile.model {:?} is not built in (built in: {REFERENCE_ID}, {}); give a mesh file instead",
                cfg.model,
                super::shapes::IDS.join(", ")
            );
        }
        Ok(ProjectileModel {
            id: REFERENCE_ID.to_string(),
            mesh: REF_1378X80.tessellate(),
            tail_x: -0.5 * REF_1378X80.length,
            body_radius: REF_1378X80.radius,
        })
    }

    /// A model from a mesh read from a file.
    pub fn from_mesh(id: String, mesh: Mesh) -> ProjectileModel {
        let tail_x = mesh
            .vertices
            .iter()
            .map(|v| v.x)
            .fold(f64::INFINITY, f64::min);
        let nose_x = mesh
            .vertices
            .iter()
            .map(|v| v.x)
            .fold(f64::NEG_INFINITY, f64::max);
        let fins_end = tail_x + FIN_ZONE * (nose_x - tail_x);
        let body_radius = mesh
            .vertices
            .iter()
            .filter(|v| v.x >= fins_end)
            .map(|v| libm::sqrt(v.y * v.y + v.z * v.z))
            .fold(0.0, f64::max);
        ProjectileModel {
            id,
            mesh,
            tail_x,
            body_radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_model_matches_the_spec() {
        let m = REF_1378X80;
        assert!((m.ogive_rho() - 0.740).abs() < 1e-12);
        assert!(m.radius_at(0.0).abs() < 1e-12);
        assert!((m.radius_at(m.nose_length) - m.radius).abs() < 1e-12);
        // Independent check against the bundled model file of the same projectile (data only).
        let core = crate::model::load(&crate::model::bundled_dir().join("ref-1378x80.model"))
            .expect("the bundled reference model");
        assert_eq!(core.id(), REFERENCE_ID);
        assert!((f64::from(core.length_m) - m.length).abs() < 1e-6);
        assert!((f64::from(core.diameter_m) - 2.0 * m.radius).abs() < 1e-6);
        let (shoulder, _) = core.cylinder_s();
        assert!((f64::from(shoulder) - m.nose_length).abs() < 1e-6);
        for s in [0.03, 0.12, 0.2, 0.6, 1.3] {
            let r = f64::from(core.radius_at(s as f32));
            assert!((r - m.radius_at(s)).abs() < 2e-5, "radius at {s}: {r}");
        }
        let fins = core.fins().expect("fins");
        assert!((f64::from(fins.tip_radius_m) - m.fin_tip_radius).abs() < 1e-6);
        assert!((f64::from(fins.root_s.1 - fins.root_s.0) - m.fin_root_chord).abs() < 1e-6);
        assert!((f64::from(fins.tip_s.1 - fins.tip_s.0) - m.fin_tip_chord).abs() < 1e-6);
        assert!((f64::from(fins.thickness_m) - m.fin_thickness).abs() < 1e-6);
        assert_eq!(u32::from(fins.count), m.fin_count);
    }

    #[test]
    fn tessellation_has_the_spec_extremes() {
        let mesh = REF_1378X80.tessellate();
        mesh.check().unwrap();
        let has = |p: Vec3| mesh.vertices.iter().any(|v| (*v - p).norm() < 1e-12);
        assert!(has(Vec3::new(0.689, 0.0, 0.0)), "nose tip");
        assert!(has(Vec3::new(-0.689, 0.0, 0.0)), "base centre");
        // The +z_B fin's trailing-edge tip, on both faces of the 4 mm plate.
        assert!(has(Vec3::new(-0.689, 0.002, 0.100)) || has(Vec3::new(-0.689, -0.002, 0.100)));
        let max_x = mesh.vertices.iter().map(|v| v.x).fold(f64::MIN, f64::max);
        let max_r = mesh
            .vertices
            .iter()
            .map(|v| libm::sqrt(v.y * v.y + v.z * v.z))
            .fold(0.0, f64::max);
        assert!((max_x - 0.689).abs() < 1e-12);
        assert!((max_r - libm::sqrt(0.1 * 0.1 + 0.002 * 0.002)).abs() < 1e-12);
        let model = ProjectileModel::from_config(&ProjectileConfig::default()).unwrap();
        assert_eq!(model.id, REFERENCE_ID);
        let from_mesh = ProjectileModel::from_mesh("x".into(), mesh);
        assert!(
            (from_mesh.body_radius - 0.040).abs() < 1e-9,
            "{}",
            from_mesh.body_radius
        );
        assert!((from_mesh.tail_x + 0.689).abs() < 1e-12);
    }
}
