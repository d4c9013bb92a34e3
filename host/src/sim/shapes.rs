//! Projectile shapes beside the reference, for clips that prove imade on any projectile: each a
//! model description (the model file's data, `crate::model::DerivedModel`) and its closed
//! triangle mesh, tessellated here from the description alone, so the simulator renders exactly
//! the shape that the model file describes.

use super::math::Vec3;
use super::mesh::Mesh;
use super::model::FinnedOgive;
use crate::model::{DerivedModel, FinPlanform};

/// Segments around the axis of a tessellated body of revolution.
const SEGMENTS: usize = 96;

/// The shapes by id: a longer finned rocket, a boat-tailed shell without fins, a six-fin design.
pub const IDS: [&str; 3] = ["rocket-2200x120", "shell-600x100", "sixfin-1000x70"];

/// The description of shape `id`, if it is one of [`IDS`].
pub fn description(id: &str) -> Option<DerivedModel> {
    match id {
        "rocket-2200x120" => Some(crate::model::describe(&FinnedOgive {
            length: 2.2,
            radius: 0.06,
            nose_length: 0.36,
            fin_count: 4,
            fin_tip_radius: 0.16,
            fin_root_chord: 0.22,
            fin_tip_chord: 0.11,
            fin_thickness: 0.006,
        })),
        "shell-600x100" => {
            // A tangent-ogive nose, a cylinder, and a 60 mm boat tail to 80 % of the diameter.
            let nose = FinnedOgive {
                length: 0.6,
                radius: 0.05,
                nose_length: 0.18,
                fin_count: 0,
                fin_tip_radius: 0.05,
                fin_root_chord: 0.0,
                fin_tip_chord: 0.0,
                fin_thickness: 0.0,
            };
            let mut model = crate::model::describe(&nose);
            model.profile.pop();
            model.profile.extend([(0.54, 0.05), (0.6, 0.04)]);
            Some(model)
        }
        "sixfin-1000x70" => Some(crate::model::describe(&FinnedOgive {
            length: 1.0,
            radius: 0.035,
            nose_length: 0.2,
            fin_count: 6,
            fin_tip_radius: 0.09,
            fin_root_chord: 0.1,
            fin_tip_chord: 0.05,
            fin_thickness: 0.004,
        })),
        _ => None,
    }
}

/// The simulator's closed mesh of built-in shape `id` (the reference or one of [`IDS`]).
pub fn mesh(id: &str) -> Option<Mesh> {
    if id == super::model::REFERENCE_ID {
        return Some(super::model::REF_1378X80.tessellate());
    }
    description(id).map(|d| tessellate(&d))
}

/// A closed triangle mesh of `model` in body frame B (origin at the middle of the length, +x_B
/// towards the nose): a ring of 96 vertices per profile station (an apex where the
/// radius is 0), flat discs closing the ends, and each fin as a closed prism whose root reaches
/// into the body.
pub fn tessellate(model: &DerivedModel) -> Mesh {
    let mut mesh = Mesh::default();
    let x_at = |s: f64| 0.5 * model.length_m - s;
    let mut previous: Option<Vec<u32>> = None;
    for &(s, r) in &model.profile {
        let current: Vec<u32> = if r > 0.0 {
            (0..SEGMENTS)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / SEGMENTS as f64;
                    mesh.push_vertex(Vec3::new(x_at(s), r * a.cos(), r * a.sin()))
                })
                .collect()
        } else {
            vec![mesh.push_vertex(Vec3::new(x_at(s), 0.0, 0.0))]
        };
        match &previous {
            None => close(&mut mesh, &current, x_at(s), true),
            Some(prev) => join(&mut mesh, prev, &current),
        }
        previous = Some(current);
    }
    if let Some((last, &(s, _))) = previous.zip(model.profile.last()) {
        close(&mut mesh, &last, x_at(s), false);
    }
    if let Some(fins) = &model.fins {
        for k in 0..fins.count {
            push_fin(&mut mesh, model, fins, k);
        }
    }
    mesh
}

/// Closes an end ring with a flat disc (nothing for an apex); `front` faces +x_B.
fn close(mesh: &mut Mesh, ring: &[u32], x: f64, front: bool) {
    if ring.len() < 2 {
        return;
    }
    let centre = mesh.push_vertex(Vec3::new(x, 0.0, 0.0));
    for k in 0..ring.len() {
        let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
        // The rings turn from +y_B towards +z_B, positively about +x_B.
        mesh.triangles.push(if front {
            [centre, a, b]
        } else {
            [centre, b, a]
        });
    }
}

/// Joins two consecutive stations: ring to ring with quads, apex to ring with a fan.
fn join(mesh: &mut Mesh, front: &[u32], back: &[u32]) {
    match (front.len(), back.len()) {
        (1, n) => {
            for k in 0..n {
                mesh.triangles.push([front[0], back[k], back[(k + 1) % n]]);
            }
        }
        (n, 1) => {
            for k in 0..n {
                mesh.triangles.push([back[0], front[(k + 1) % n], front[k]]);
            }
        }
        (n, _) => {
            for k in 0..n {
                let k1 = (k + 1) % n;
                mesh.push_quad(front[k], back[k], back[k1], front[k1]);
            }
        }
    }
}

/// Fin `index` as a closed prism: the planform's root chord moved half-way into the body along
/// its edges, so it meets the round surface without a gap.
fn push_fin(mesh: &mut Mesh, model: &DerivedModel, fins: &FinPlanform, index: u32) {
    let roll =
        (fins.first_fin_roll_deg + 360.0 * f64::from(index) / f64::from(fins.count)).to_radians();
    let out = Vec3::new(0.0, roll.cos(), roll.sin());
    let body = model.diameter_m * 0.5;
    let root_r = 0.5 * body;
    // Extend the leading and trailing edges from the body's radius inwards to root_r.
    let inward = |root_s: f64, tip_s: f64| {
        root_s + (tip_s - root_s) * (root_r - body) / (fins.tip_radius_m - body)
    };
    let outline = [
        (inward(fins.root_le_s, fins.tip_le_s), root_r),
        (fins.tip_le_s, fins.tip_radius_m),
        (fins.tip_te_s, fins.tip_radius_m),
        (inward(fins.root_te_s, fins.tip_te_s), root_r),
    ];
    push_plate(mesh, model.length_m, &outline, out, fins.thickness_m);
}

/// A flat plate of `thickness` m as a closed prism: its `outline` of four (s aft of the tip, r
/// from the axis) corners, in the plane of the axis and the unit vector `out`, on a body
/// `length` m long.
pub fn push_plate(
    mesh: &mut Mesh,
    length: f64,
    outline: &[(f64, f64); 4],
    out: Vec3,
    thickness: f64,
) {
    let across = Vec3::new(1.0, 0.0, 0.0).cross(out);
    let half = 0.5 * thickness;
    let corners: Vec<[u32; 2]> = outline
        .iter()
        .map(|&(s, r)| {
            let centre = Vec3::new(0.5 * length - s, 0.0, 0.0) + out * r;
            [
                mesh.push_vertex(centre + across * half),
                mesh.push_vertex(centre - across * half),
            ]
        })
        .collect();
    mesh.push_quad(corners[0][0], corners[1][0], corners[2][0], corners[3][0]);
    mesh.push_quad(corners[3][1], corners[2][1], corners[1][1], corners[0][1]);
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        mesh.push_quad(a[0], a[1], b[1], b[0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each shape's mesh is closed and wound outwards, and the mesh-to-model derivation gives back
    /// its description.
    #[test]
    fn each_shape_is_derived_back_from_its_mesh() {
        for id in IDS {
            let model = description(id).unwrap();
            let mesh = tessellate(&model);
            let (derived, report) = crate::mesh_model::derive(&mesh, Some(model.diameter_m))
                .unwrap_or_else(|e| panic!("{id}: {e}"));
            println!("{id}:\n{report}");
            // Closed and wound outwards throughout (other renderers cull back faces).
            assert!(report.warnings.is_empty(), "{id}: {:?}", report.warnings);
            // The derived description encodes as a model file the core accepts.
            crate::model::encode(id, &derived, None).unwrap_or_else(|e| panic!("{id}: {e:#}"));
            assert!((derived.length_m - model.length_m).abs() < 1e-3, "{id}");
            assert!(
                (derived.diameter_m / model.diameter_m - 1.0).abs() < 0.005,
                "{id}"
            );
            let base = |m: &DerivedModel| m.profile.last().unwrap().1;
            assert!((base(&derived) - base(&model)).abs() < 1e-3, "{id} base");
            match (&derived.fins, &model.fins) {
                (Some(d), Some(m)) => {
                    assert_eq!(d.count, m.count, "{id}");
                    assert!((d.tip_radius_m - m.tip_radius_m).abs() < 2e-3, "{id}");
                    assert!(
                        ((d.root_te_s - d.root_le_s) - (m.root_te_s - m.root_le_s)).abs() < 3e-3,
                        "{id}"
                    );
                }
                (None, None) => {}
                (d, m) => panic!("{id}: fins {d:?} from the mesh, {m:?} described"),
            }
        }
    }
}
