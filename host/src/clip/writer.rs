//! Writing a clip: `clip.json`, the chips and masks, and `frames.csv` (written atomically at the end).

use super::chip_image::ChipImage;
use super::frames::{FrameRow, RawRow};
use super::meta::ClipMeta;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Writes an `imade-clip/1` folder frame by frame. Call [`ClipWriter::finish`] to write
/// `frames.csv`; a writer dropped before that leaves no `frames.csv`, so a half-written clip is
/// never mistaken for a whole one.
pub struct ClipWriter {
    dir: PathBuf,
    rows: Vec<RawRow>,
}

impl ClipWriter {
    /// Creates the clip folder (and `chips/`, `masks/`) and writes `clip.json`.
    pub fn create(dir: &Path, meta: &ClipMeta) -> anyhow::Result<ClipWriter> {
        std::fs::create_dir_all(dir.join("chips"))
            .with_context(|| format!("creating {}", dir.display()))?;
        std::fs::create_dir_all(dir.join("masks"))
            .with_context(|| format!("creating {}", dir.display()))?;
        let json = serde_json::to_string_pretty(meta)?;
        write_atomically(&dir.join("clip.json"), json.as_bytes())?;
        Ok(ClipWriter {
            dir: dir.to_path_buf(),
            rows: Vec::new(),
        })
    }

    /// Writes one frame: its chip as `chips/NNNNNN.png`, its ground-truth mask (if any) as
    /// `masks/NNNNNN.png`, and remembers its row. The `chip` and `gt_mask` fields of `row` are
    /// replaced by the conventional paths.
    pub fn write_frame(
        &mut self,
        row: &FrameRow,
        chip: &ChipImage,
        mask: Option<&image::GrayImage>,
    ) -> anyhow::Result<()> {
        let chip_rel = format!("chips/{:06}.png", row.frame);
        chip.save_png(&self.dir.join(&chip_rel))?;
        let mask_rel = match mask {
            Some(m) => {
                let rel = format!("masks/{:06}.png", row.frame);
                let path = self.dir.join(&rel);
                m.save_with_format(&path, image::ImageFormat::Png)
                    .with_context(|| format!("writing {}", path.display()))?;
                Some(rel)
            }
            None => None,
        };
        let num = |v: f64| Some(format!("{v}"));
        let truth = row.truth;
        self.rows.push(RawRow {
            frame: Some(row.frame.to_string()),
            time_s: num(row.time_s),
            chip: Some(chip_rel),
            chip_x0: Some(row.chip_x0.to_string()),
            chip_y0: Some(row.chip_y0.to_string()),
            range_m: row.range_m.and_then(num),
            mount_az_deg: row.mount.and_then(|m| num(m.az_deg())),
            mount_el_deg: row.mount.and_then(|m| num(m.el_deg())),
            gt_tx_m: truth.and_then(|t| num(t.tx_m)),
            gt_ty_m: truth.and_then(|t| num(t.ty_m)),
            gt_tz_m: truth.and_then(|t| num(t.tz_m)),
            gt_pitch_deg: truth.and_then(|t| num(t.pitch_deg)),
            gt_yaw_deg: truth.and_then(|t| num(t.yaw_deg)),
            gt_roll_deg: truth.and_then(|t| num(t.roll_deg)),
            gt_mask: mask_rel,
            gt_aoa_deg: row.truth_aoa.and_then(|a| num(a.total_deg)),
            gt_aoa_up_deg: row.truth_aoa.and_then(|a| num(a.up_deg)),
            gt_aoa_right_deg: row.truth_aoa.and_then(|a| num(a.right_deg)),
        });
        Ok(())
    }

    /// Writes `frames.csv` atomically and returns the clip folder.
    pub fn finish(self) -> anyhow::Result<PathBuf> {
        let mut out = csv::Writer::from_writer(Vec::new());
        for row in &self.rows {
            out.serialize(row)?;
        }
        let bytes = out.into_inner().context("flushing frames.csv")?;
        write_atomically(&self.dir.join("frames.csv"), &bytes)?;
        Ok(self.dir)
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that a
/// reader never sees a partial file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    tmp.write_all(bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    tmp.persist(path)
        .with_context(|| format!("renaming into {}", path.display()))?;
    Ok(())
}
