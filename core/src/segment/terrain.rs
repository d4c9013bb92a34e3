//! Terrain entering the chip from its lower edge.
//!
//! Below the horizon the chip shows ground, far darker (or brighter) than the sky. The tile
//! model takes each tile's median, so a tile of terrain gets the terrain's level: the terrain
//! itself then looks like sky, and only a strip along the ridge, where the tiles' interpolation
//! lies between the two levels, stands out, shaped like a long, thin body clear of the chip's
//! edge. [`Horizon::find`] finds the terrain instead: where the lower edge's tiles differ from
//! the sky of the top row by more than [`TerrainConfig::min_contrast_sigma`] noise sigmas (or
//! are darker by [`TerrainConfig::min_dark_contrast_sigma`]) over at least
//! [`TerrainConfig::min_width_fraction`] of the chip's width, each column is followed up from
//! the lower edge while its pixels lie on the terrain's side of the level halfway between the
//! two. The background then takes its sky from above the horizon only
//! ([`Background::estimate_terrain`](super::background::Background::estimate_terrain)), so that
//! the terrain stands out whole and reaches the chip's edge (a candidate there is never the
//! body).

use crate::capacity::MAX_CHIP_SIDE;
use crate::chip::ChipView;

/// When terrain is looked for along the chip's lower edge.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TerrainConfig {
    /// Tiles along the lower edge are terrain where their level differs from the sky's (the
    /// median of the top row's tiles) by at least this many noise sigmas: more than a faint
    /// body's contrast or a cloud's shading ...
    pub min_contrast_sigma: f32,
    /// ... or, darker than the sky, by at least this many: by day the ground seen through the
    /// haze is darker than the sky above the horizon, and hazy ridges 10-20 sigmas dark broke
    /// into ridge fragments the size of a body, while a band this bright at the lower edge is
    /// more often a sunlit cloud ...
    pub min_dark_contrast_sigma: f32,
    /// ... and where such tiles, all on one side of the sky, cover at least this fraction of
    /// the chip's width (a plume or a body at the edge covers less).
    pub min_width_fraction: f32,
    /// A column's terrain ends above the last of its pixels on the terrain's side of the
    /// halfway level before this many px off it (the terrain's texture, the noise).
    pub gap_px: u16,
    /// The sky is taken from pixels at least this many px above the horizon (the blur).
    pub margin_px: u16,
    /// The horizon is sharp: 3 px this far above a column's top lie at least this fraction of
    /// the way from the terrain's level to the sky's on average, and 3 px this far below it at
    /// most `1 -` this fraction (a smooth gradient of the sky, or a cloud's shade, is not
    /// terrain) ...
    pub edge_fraction: f32,
    /// ... `edge_px` px ...
    pub edge_px: u16,
    /// ... in at least this fraction of the columns that have terrain.
    pub min_sharp_fraction: f32,
    /// In at least this fraction of the columns that have terrain, the horizon lies below the
    /// chip's middle row: the mount keeps the projectile, in the sky, near the chip's middle
    /// (the sky below a bright cloud band high in the chip is no terrain).
    pub min_low_fraction: f32,
}

impl TerrainConfig {
    /// The defaults.
    pub const DEFAULT: TerrainConfig = TerrainConfig {
        min_contrast_sigma: 20.0,
        min_dark_contrast_sigma: 10.0,
        min_width_fraction: 0.25,
        gap_px: 3,
        margin_px: 2,
        edge_fraction: 0.7,
        edge_px: 5,
        min_sharp_fraction: 0.5,
        min_low_fraction: 0.5,
    };
}

impl Default for TerrainConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The terrain's top in every column of the chip (none where no terrain was found).
pub struct Horizon {
    /// Per column, the topmost row of the terrain (the chip's height: no terrain there).
    top: [u16; MAX_CHIP_SIDE],
    width: usize,
    height: usize,
    present: bool,
}

impl Default for Horizon {
    fn default() -> Self {
        Self::new()
    }
}

impl Horizon {
    /// No terrain.
    pub const fn new() -> Self {
        Horizon {
            top: [0; MAX_CHIP_SIDE],
            width: 0,
            height: 0,
            present: false,
        }
    }

    /// The topmost row of terrain in column `x`, where the column has terrain.
    pub fn top(&self, x: usize) -> Option<usize> {
        if !self.present || x >= self.width {
            return None;
        }
        let top = usize::from(*self.top.get(x)?);
        (top < self.height).then_some(top)
    }

    /// Whether pixel (`x`, `y`) lies on the terrain or within `margin_px` above it.
    pub fn covers(&self, x: usize, y: usize, margin_px: usize) -> bool {
        self.top(x).is_some_and(|top| y + margin_px >= top)
    }

    /// Finds the terrain of `chip` (noise `sigma` grey levels) whose lower edge's tiles have
    /// the levels `bottom_levels` (left to right, `tile_px` px wide), against the sky level
    /// `sky`; returns whether there is any.
    pub fn find(
        &mut self,
        chip: &ChipView,
        sky: f32,
        sigma: f32,
        (bottom_levels, tile_px): (&[f32], usize),
        config: &TerrainConfig,
    ) -> bool {
        self.width = chip.width().min(MAX_CHIP_SIDE);
        self.height = chip.height();
        self.present = false;
        let Some(level) = terrain_level(sky, sigma, bottom_levels, tile_px, self.width, config)
        else {
            return false;
        };
        // A pixel is terrain on the terrain's side of the level halfway to the sky.
        let halfway = 0.5 * (sky + level);
        let side = if level > sky { 1.0 } else { -1.0 };
        let terrain = |v: u16| side * (f32::from(v) - halfway) > 0.0;
        let height = self.height;
        // The way from the terrain's level to the sky's of the mean of 3 px of column `x` from
        // row `y` up (None: off the chip).
        let way = |x: usize, y: usize| {
            if y >= height {
                return None;
            }
            let sum: f32 = (y.checked_sub(2)?..=y)
                .map(|r| f32::from(chip.get(x, r)))
                .sum();
            Some((sum / 3.0 - level) / (sky - level))
        };
        let gap = usize::from(config.gap_px.max(1));
        let edge = usize::from(config.edge_px);
        let (mut with_terrain, mut sharp, mut low) = (0usize, 0usize, 0usize);
        for (x, top) in self.top.iter_mut().enumerate().take(self.width) {
            let mut highest = height;
            for y in (0..height).rev() {
                if terrain(chip.get(x, y)) {
                    highest = y;
                } else if highest - y > gap {
                    break;
                }
            }
            *top = u16::try_from(highest).unwrap_or(u16::MAX);
            if highest < height {
                with_terrain += 1;
                low += usize::from(2 * highest >= height);
                let above = highest.checked_sub(edge).and_then(|y| way(x, y));
                let below = way(x, highest + edge + 2);
                // A column whose terrain ends within the edge's reach of the chip's bottom has
                // nothing below to judge by: its top alone.
                let below_ok = below.is_none_or(|w| w <= 1.0 - config.edge_fraction);
                if above.is_some_and(|w| w >= config.edge_fraction) && below_ok {
                    sharp += 1;
                }
            }
        }
        let share = |count: usize| count as f32 / with_terrain.max(1) as f32;
        self.present = with_terrain > 0
            && share(sharp) >= config.min_sharp_fraction
            && share(low) >= config.min_low_fraction;
        self.present
    }
}

/// The terrain's level: the mean of the lower edge's tile levels that differ from `sky` by at
/// least the config's contrast (of their side), all on the side of the one that differs most,
/// where they cover at least the config's fraction of the chip's `width` px (None: no terrain).
fn terrain_level(
    sky: f32,
    sigma: f32,
    bottom_levels: &[f32],
    tile_px: usize,
    width: usize,
    config: &TerrainConfig,
) -> Option<f32> {
    let farthest = bottom_levels
        .iter()
        .copied()
        .max_by(|a, b| libm::fabsf(a - sky).total_cmp(&libm::fabsf(b - sky)))?;
    let (side, min_contrast) = if farthest > sky {
        (1.0, config.min_contrast_sigma * sigma)
    } else {
        (-1.0, config.min_dark_contrast_sigma * sigma)
    };
    let (sum, count) = bottom_levels
        .iter()
        .filter(|l| side * (**l - sky) >= min_contrast)
        .fold((0.0f32, 0usize), |(s, n), l| (s + l, n + 1));
    let covered = (count * tile_px).min(width) as f32;
    (count > 0 && covered >= config.min_width_fraction * width as f32).then(|| sum / count as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIDE: usize = 64;

    /// A sky of 150 with terrain of 60 below a ridge at row `ridge(x)`, and a dark bar of 140
    /// (a faint body) at rows 20-22.
    fn chip_with_ridge(ridge: impl Fn(usize) -> usize) -> [u8; SIDE * SIDE] {
        let mut pixels = [150u8; SIDE * SIDE];
        for (i, p) in pixels.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            if y >= ridge(x) {
                // Textured ground, never as bright as halfway to the sky.
                *p = 60 + ((x * 7 + y * 13) % 30) as u8;
            } else if (20..23).contains(&y) && (10..50).contains(&x) {
                *p = 140;
            }
        }
        pixels
    }

    fn bottom_levels(pixels: &[u8]) -> [f32; 2] {
        let mean = |x0: usize| {
            let tile = (SIDE - 32..SIDE).flat_map(|y| (x0..x0 + 32).map(move |x| (x, y)));
            tile.map(|(x, y)| f32::from(pixels[y * SIDE + x]))
                .sum::<f32>()
                / 1024.0
        };
        [mean(0), mean(32)]
    }

    #[test]
    fn the_horizon_follows_the_ridge_from_the_lower_edge() {
        let ridge = |x: usize| 40 + (x % 16).min(16 - x % 16);
        let pixels = chip_with_ridge(ridge);
        let chip = ChipView::gray8(&pixels, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut horizon = Horizon::new();
        let levels = bottom_levels(&pixels);
        assert!(horizon.find(&chip, 150.0, 2.0, (&levels, 32), &TerrainConfig::DEFAULT));
        for x in 0..SIDE {
            assert_eq!(horizon.top(x), Some(ridge(x)), "column {x}");
        }
        // The faint body above it is sky to the horizon.
        assert!(!horizon.covers(30, 22, 2));
        assert!(horizon.covers(30, ridge(30) - 2, 2));
    }

    #[test]
    fn no_terrain_where_the_lower_edge_is_sky_or_only_a_little_darker() {
        let pixels = chip_with_ridge(|_| SIDE);
        let chip = ChipView::gray8(&pixels, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut horizon = Horizon::new();
        let config = TerrainConfig::DEFAULT;
        assert!(!horizon.find(&chip, 150.0, 2.0, (&bottom_levels(&pixels), 32), &config));
        assert_eq!(horizon.top(10), None);
        // A cloud's shade 8 sigmas darker, or terrain under only a tenth of the width, is not.
        let shaded = [134.0, 150.0];
        assert!(!horizon.find(&chip, 150.0, 2.0, (&shaded, 32), &config));
        let narrow = [60.0, 150.0];
        let config = TerrainConfig {
            min_width_fraction: 0.6,
            ..config
        };
        assert!(!horizon.find(&chip, 150.0, 2.0, (&narrow, 32), &config));
    }

    #[test]
    fn a_smooth_gradient_of_the_sky_is_not_terrain() {
        // 208 at the top to 160 at the bottom: the lower edge is 24 sigmas darker, but gradually.
        let mut pixels = [0u8; SIDE * SIDE];
        for (i, p) in pixels.iter_mut().enumerate() {
            *p = (208.0 - 48.0 * (i / SIDE) as f32 / (SIDE - 1) as f32) as u8;
        }
        let chip = ChipView::gray8(&pixels, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut horizon = Horizon::new();
        let levels = bottom_levels(&pixels);
        let config = TerrainConfig::DEFAULT;
        assert!(!horizon.find(&chip, 208.0, 2.0, (&levels, 32), &config));
        // The same levels with a sharp step are terrain.
        let stepped = chip_with_ridge(|_| 40);
        let chip = ChipView::gray8(&stepped, SIDE, SIDE, SIDE, 0, 0).unwrap();
        assert!(horizon.find(&chip, 150.0, 2.0, (&bottom_levels(&stepped), 32), &config));
    }

    #[test]
    fn the_sky_below_a_bright_band_high_in_the_chip_is_not_terrain() {
        // Sky of 60 below a sharp band of 150 at rows 0-19: the lower edge is 45 sigmas darker
        // than the top row and its edge sharp, but high above the chip's middle.
        let pixels = chip_with_ridge(|_| 20);
        let chip = ChipView::gray8(&pixels, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut horizon = Horizon::new();
        let levels = bottom_levels(&pixels);
        let config = TerrainConfig::DEFAULT;
        assert!(!horizon.find(&chip, 150.0, 2.0, (&levels, 32), &config));
        let anywhere = TerrainConfig {
            min_low_fraction: 0.0,
            ..config
        };
        assert!(horizon.find(&chip, 150.0, 2.0, (&levels, 32), &anywhere));
    }

    /// A hazy ridge only 13-17 noise sigmas darker than the sky (its texture) is terrain; the
    /// same band as much brighter, more often a sunlit cloud, is not.
    #[test]
    fn a_hazy_ridge_is_terrain_where_darker_than_the_sky() {
        let ridge = |x: usize| 34 + (x % 8).min(8 - x % 8);
        let hazy = |toward: i32| {
            let mut pixels = chip_with_ridge(ridge);
            for (i, p) in pixels.iter_mut().enumerate() {
                let (x, y) = (i % SIDE, i / SIDE);
                if y >= ridge(x) {
                    *p = (150 + toward * (34 - ((x * 7 + y * 13) % 8) as i32)) as u8;
                }
            }
            pixels
        };
        let config = TerrainConfig::DEFAULT;
        let mut horizon = Horizon::new();
        let dark = hazy(-1);
        let chip = ChipView::gray8(&dark, SIDE, SIDE, SIDE, 0, 0).unwrap();
        assert!(horizon.find(&chip, 150.0, 2.0, (&bottom_levels(&dark), 32), &config));
        assert_eq!(horizon.top(5), Some(ridge(5)));
        let bright = hazy(1);
        let chip = ChipView::gray8(&bright, SIDE, SIDE, SIDE, 0, 0).unwrap();
        assert!(!horizon.find(&chip, 150.0, 2.0, (&bottom_levels(&bright), 32), &config));
    }
}
