//! Every fixed capacity of the core, in one place. Buffers are sized from these at compile time;
//! exceeding one at run time is a reported [`Status`](crate::Status), never a panic and never a
//! silent truncation.

/// Largest chip width or height, px.
pub const MAX_CHIP_SIDE: usize = 512;

/// Largest number of chip pixels.
pub const MAX_CHIP_PIXELS: usize = MAX_CHIP_SIDE * MAX_CHIP_SIDE;

/// 32-bit words of a bit-packed mask of a square chip `side` px wide (rows padded to whole words).
pub const fn mask_words(side: usize) -> usize {
    side.div_ceil(32) * side
}

/// 32-bit words of a bit-packed mask of [`MAX_CHIP_PIXELS`] (32 KiB): the default size of the
/// pipeline's masks (`Pipeline`'s `MASK_WORDS`; a smaller one reports larger chips as a
/// capacity).
pub const MASK_WORDS: usize = mask_words(MAX_CHIP_SIDE);

/// Default capacity of the run table of the connected-component labeler (8 bytes a run).
pub const DEFAULT_MAX_RUNS: usize = 4096;

/// Default capacity of the provisional-label table of the labeler (one statistics record each).
pub const DEFAULT_MAX_LABELS: usize = 512;

/// Largest number of components (of at least the minimum area) kept for target selection.
pub const MAX_COMPONENTS: usize = 64;

/// Blocks of the bar search's grid ([`crate::segment::bar`]): a 256 x 256 chip in blocks of
/// 4 px (a 7-px body); coarser blocks where the chip or the body is larger.
pub const BAR_GRID_CELLS: usize = 4096;

/// Largest number of components merged into one target (the main one and its fragments).
pub const MAX_TARGET_PARTS: usize = 8;

/// Side of a background-model tile, px.
pub const BACKGROUND_TILE: usize = 32;

/// Background tiles along one side of the largest chip.
pub const MAX_TILES_PER_SIDE: usize = MAX_CHIP_SIDE.div_ceil(BACKGROUND_TILE);

/// Samples of neighbour differences drawn for the noise estimate.
pub const NOISE_SAMPLES: usize = 2048;

/// Bins of the axial profile (1 px each): longer than the diagonal of the largest chip.
pub const PROFILE_BINS: usize = 768;

/// Frames in the temporal window (yaw disambiguation and Tz trend).
pub const MAX_WINDOW: usize = 32;

/// Cells of the oriented sampling grid of shape-guided segmentation (SIS-Cut's region labels,
/// GVF-ASM's edge map and flow field): the prior's region plus a margin is sampled onto at most
/// this many cells, coarser than 1 px when the region is larger.
pub const SHAPE_GRID_CELLS: usize = 3072;

/// Boundary points of the shape prior that GVF-ASM moves (a longer boundary is strided down).
pub const SHAPE_BOUNDARY_POINTS: usize = 512;

/// Largest number of intensity-histogram bins of SIS-Cut.
pub const SHAPE_HIST_BINS: usize = 64;

/// Columns of the grey-level fit's outlines ([`crate::grey_fit::outline`]): three live during
/// the fit, 8 bytes a column each.
pub const OUTLINE_COLUMNS: usize = 512;
