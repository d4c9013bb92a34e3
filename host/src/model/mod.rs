//! Model files (`imade-model/1`, `docs/model-format.md`): the projectile's geometry and its
//! silhouette table in one checksummed file, which the core validates and reads in place.
//! Encoding a description ([`encode`]), the built-in reference's description ([`reference()`]),
//! and finding the model a clip names ([`for_clip`]).

pub mod command;

use crate::sim::model::{FinnedOgive, REF_1378X80 as REFERENCE_SHAPE};
use anyhow::{Context, bail};
use imade_core::bytes::CRC;
use imade_core::lut::table::Table;
use imade_core::model::ProjectileModel;
use imade_core::model::format::{FIELD, HEADER_LEN, MAGIC, MAX_STATIONS, MODEL_ID_LEN, VERSION};
use std::path::{Path, PathBuf};

/// A projectile's geometry, in metres, `s` measured aft of the nose tip.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivedModel {
    /// Nose tip to base.
    pub length_m: f64,
    /// The body's largest diameter, fins excluded.
    pub diameter_m: f64,
    /// (s, radius) of the body of revolution: s strictly increasing from 0 to `length_m`, at
    /// most 64 stations, linear between them.
    pub profile: Vec<(f64, f64)>,
    /// The fins, if any.
    pub fins: Option<FinPlanform>,
}

/// Identical flat fins evenly spaced in roll, with a trapezoidal planform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinPlanform {
    /// Number of fins.
    pub count: u32,
    /// Root chord's leading edge, m aft of the tip.
    pub root_le_s: f64,
    /// Root chord's trailing edge, m aft of the tip.
    pub root_te_s: f64,
    /// Tip chord's leading edge, m aft of the tip.
    pub tip_le_s: f64,
    /// Tip chord's trailing edge, m aft of the tip.
    pub tip_te_s: f64,
    /// Distance of the tip chord from the axis, m.
    pub tip_radius_m: f64,
    /// Thickness, m.
    pub thickness_m: f64,
    /// Roll of fin 0 about +x_B from +y_B towards +z_B, deg.
    pub first_fin_roll_deg: f64,
}

/// Stations of the reference's tangent-ogive nose in its model file (the tip included).
const REFERENCE_NOSE_STATIONS: usize = 48;

/// The description of the built-in reference projectile `ref-1378x80` (`docs/projectile.md`):
/// its ogive sampled densest at the tip, where it curves most.
pub fn reference() -> DerivedModel {
    describe(&REFERENCE_SHAPE)
}

/// The description of a finned tangent-ogive body (the simulator's analytic shape).
pub fn describe(shape: &FinnedOgive) -> DerivedModel {
    let n = REFERENCE_NOSE_STATIONS - 1;
    let mut profile: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            // s grows as (i/n)^2: short steps at the tip.
            let u = i as f64 / n as f64;
            let s = shape.nose_length * u * u;
            (s, shape.radius_at(s))
        })
        .collect();
    profile.push((shape.length, shape.radius));
    let root = shape.length - shape.fin_root_chord;
    let tip = shape.length - shape.fin_tip_chord;
    DerivedModel {
        length_m: shape.length,
        diameter_m: 2.0 * shape.radius,
        profile,
        fins: (shape.fin_count > 0).then_some(FinPlanform {
            count: shape.fin_count,
            root_le_s: root,
            root_te_s: shape.length,
            tip_le_s: tip,
            tip_te_s: shape.length,
            tip_radius_m: shape.fin_tip_radius,
            thickness_m: shape.fin_thickness,
            first_fin_roll_deg: 0.0,
        }),
    }
}

/// The model file of `model` named `id`, with the silhouette table `table` (imade-lut/1 bytes)
/// when given. Fails on what the core would refuse: an id too long, too many stations.
pub fn encode(id: &str, model: &DerivedModel, table: Option<&[u8]>) -> anyhow::Result<Vec<u8>> {
    if id.is_empty() || id.len() > MODEL_ID_LEN {
        bail!("model id {id:?}: 1 to {MODEL_ID_LEN} bytes of UTF-8");
    }
    if !(2..=MAX_STATIONS).contains(&model.profile.len()) {
        bail!(
            "the profile has {} stations; a model file holds 2 to {MAX_STATIONS}",
            model.profile.len()
        );
    }
    let table = table.unwrap_or(&[]);
    let mut bytes = vec![0u8; HEADER_LEN];
    let put = |bytes: &mut Vec<u8>, at: usize, field: &[u8]| {
        bytes[at..at + field.len()].copy_from_slice(field);
    };
    let f32_le = |v: f64| (v as f32).to_le_bytes();
    put(&mut bytes, 0, &MAGIC);
    put(&mut bytes, 8, &VERSION.to_le_bytes());
    put(&mut bytes, 10, &(HEADER_LEN as u16).to_le_bytes());
    put(&mut bytes, FIELD.id, id.as_bytes());
    put(&mut bytes, FIELD.length, &f32_le(model.length_m));
    put(&mut bytes, FIELD.diameter, &f32_le(model.diameter_m));
    put(
        &mut bytes,
        FIELD.stations,
        &(model.profile.len() as u16).to_le_bytes(),
    );
    if let Some(f) = &model.fins {
        put(
            &mut bytes,
            FIELD.fin_count,
            &u16::try_from(f.count)?.to_le_bytes(),
        );
        put(&mut bytes, FIELD.fin_root_le, &f32_le(f.root_le_s));
        put(&mut bytes, FIELD.fin_root_te, &f32_le(f.root_te_s));
        put(&mut bytes, FIELD.fin_tip_le, &f32_le(f.tip_le_s));
        put(&mut bytes, FIELD.fin_tip_te, &f32_le(f.tip_te_s));
        put(&mut bytes, FIELD.fin_tip_radius, &f32_le(f.tip_radius_m));
        put(&mut bytes, FIELD.fin_thickness, &f32_le(f.thickness_m));
        put(
            &mut bytes,
            FIELD.fin_first_roll,
            &f32_le(f.first_fin_roll_deg),
        );
    }
    put(
        &mut bytes,
        FIELD.table_len,
        &u32::try_from(table.len())?.to_le_bytes(),
    );
    for &(s, r) in &model.profile {
        bytes.extend_from_slice(&f32_le(s));
        bytes.extend_from_slice(&f32_le(r));
    }
    bytes.extend_from_slice(table);
    let crc = CRC.checksum(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    ProjectileModel::parse(&bytes)
        .map_err(|e| anyhow::anyhow!("the encoded model does not validate: {e:?}"))?;
    Ok(bytes)
}

/// Where the bundled model files live: `fixtures/models/` of the source tree.
pub fn bundled_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/models")
}

/// Reads and validates the model file at `path`, keeping its bytes for the life of the process
/// (the core borrows models as `&'static [u8]`, as from flash).
pub fn load(path: &Path) -> anyhow::Result<ProjectileModel<'static>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading model {}", path.display()))?;
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    ProjectileModel::parse(bytes)
        .map_err(|e| anyhow::anyhow!("{}: not a valid model file: {e:?}", path.display()))
}

/// The silhouette table of `model` for the table choice `lut` (`--lut`): none for `none`, else
/// the one the model file carries.
pub fn table_for(lut: &str, model: &ProjectileModel<'static>) -> Option<Table<'static>> {
    (lut != "none").then(|| model.table()).flatten()
}

/// The model a clip names (`projectile` in `clip.json`): from the model file `file` when one is
/// given (its id must be the clip's), else the bundled one of that id.
pub fn for_clip(projectile: &str, file: Option<&Path>) -> anyhow::Result<ProjectileModel<'static>> {
    let model = match file {
        Some(path) => load(path)?,
        None => {
            let path = bundled_dir().join(format!("{projectile}.model"));
            if !path.exists() {
                bail!(
                    "unknown projectile {projectile:?}: no bundled model {} (build one from its \
                     mesh with `imade model build --mesh FILE --id {projectile} --out FILE` and \
                     give it with --lut FILE)",
                    path.display()
                );
            }
            load(&path)?
        }
    };
    if model.id() != projectile {
        bail!(
            "the model file is for {:?}, the clip's projectile is {projectile:?}",
            model.id()
        );
    }
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;
    use imade_core::ModelError;

    #[test]
    fn the_reference_round_trips_through_its_file() {
        let description = reference();
        let bytes = encode("ref-1378x80", &description, None).unwrap();
        let model = ProjectileModel::parse(&bytes).unwrap();
        assert_eq!(model.id(), "ref-1378x80");
        assert_eq!(model.stations(), description.profile.len());
        for &(s, r) in &description.profile {
            assert!(
                (f64::from(model.radius_at(s as f32)) - r).abs() < 1e-6,
                "at {s}"
            );
        }
        assert_eq!(model.fins().unwrap().count, 4);
        assert_eq!(model.distinct_roll_deg(), 45.0);
        assert!(model.table().is_none());
    }

    /// `fixtures/README.md`'s command reproduces the bundled reference model byte for byte.
    #[test]
    fn the_bundled_reference_model_is_reproduced() {
        let table = std::fs::read(bundled_dir().join("../lut/ref-1378x80.lut")).unwrap();
        let bytes = encode("ref-1378x80", &reference(), Some(&table)).unwrap();
        let bundled = std::fs::read(bundled_dir().join("ref-1378x80.model")).unwrap();
        assert!(
            bytes == bundled,
            "fixtures/models/ref-1378x80.model differs: rebuild it"
        );
    }

    #[test]
    fn fins_set_the_distinct_rolls() {
        let mut six = reference();
        six.fins.as_mut().unwrap().count = 6;
        let bytes = encode("six", &six, None).unwrap();
        assert_eq!(
            ProjectileModel::parse(&bytes).unwrap().distinct_roll_deg(),
            30.0
        );
        let bare = DerivedModel {
            fins: None,
            ..reference()
        };
        let bytes = encode("bare", &bare, None).unwrap();
        let model = ProjectileModel::parse(&bytes).unwrap();
        assert_eq!(
            (model.distinct_roll_deg(), model.max_radius_m()),
            (0.0, 0.04)
        );
    }

    #[test]
    fn bad_models_are_refused() {
        let shape = reference();
        // A profile that does not start at the tip, or that goes backwards.
        let mut late = shape.clone();
        late.profile[0].0 = 0.01;
        assert!(encode("x", &late, None).is_err());
        let mut backwards = shape.clone();
        backwards.profile.swap(3, 4);
        assert!(encode("x", &backwards, None).is_err());
        // A fin whose leading edge is behind its trailing edge.
        let mut fin = shape.clone();
        fin.fins.as_mut().unwrap().root_le_s = 1.5;
        assert!(encode("x", &fin, None).is_err());
        assert!(encode("", &shape, None).is_err());
        assert!(encode(&"x".repeat(33), &shape, None).is_err());
        // A damaged file.
        let mut bytes = encode("x", &shape, None).unwrap();
        bytes[130] ^= 1;
        assert_eq!(
            ProjectileModel::parse(&bytes).err(),
            Some(ModelError::Checksum)
        );
        bytes[130] ^= 1;
        bytes[8] = 2;
        assert!(matches!(
            ProjectileModel::parse(&bytes).err(),
            Some(ModelError::Version(2))
        ));
        // A table built for another model.
        let table = std::fs::read(bundled_dir().join("../lut/ref-1378x80.lut")).unwrap();
        let other = DerivedModel {
            length_m: 1.5,
            ..shape.clone()
        };
        let mut longer = other.clone();
        longer.profile.last_mut().unwrap().0 = 1.5;
        assert!(encode("ref-1378x80", &longer, Some(&table)).is_err());
        assert!(encode("ref-1378x80", &shape, Some(&table)).is_ok());
    }
}
