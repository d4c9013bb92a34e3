//! The table-match stage: the closed-form hypothesis matched against the model's silhouette
//! table, the shape prior, and the source paper's shape-guided loop.
//!
//! The source paper refines its closed-form pose by matching the mask against the model's
//! rendered silhouette. Here the model's silhouettes are precomputed ([`crate::lut`]) and matched
//! on grey levels rather than on a thresholded mask ([`pose`]: the shaded cross-section of
//! [`section`], the width profile, the entry search of [`search`]). The matched silhouette is
//! drawn as the shape prior; with a [`GuidedMethod`] (feature `shape-guided`) the prior guides a
//! segmentation of the chip whose transform moves the match's axis and ends, and the match is
//! made again ([`guided_loop`]).

#[cfg(feature = "shape-guided")]
pub mod guided_loop;
pub mod pose;
pub mod search;
pub mod section;

pub use pose::{MatchError, MatchInput, MatchedPose};

use crate::camera::Camera;
use crate::chip::ChipView;
use crate::closed_form::{ClosedForm, Hypothesis};
use crate::config::BodyPolarity;
use crate::grey_fit::GreyFitted;
use crate::lut::render::{self, Placement, View};
use crate::lut::table::Table;
use crate::mask::BitMask;
use crate::model::ProjectileModel;
use crate::segment::background::Background;
#[cfg(feature = "shape-guided")]
use crate::shape_guided::{ShapeGuided, ShapeGuidedConfig};
#[cfg(feature = "shape-guided")]
use guided_loop::LoopOutcome;

/// A shape-guided segmentation method (the paper's third module).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GuidedMethod {
    /// Shape-incorporated segmentation with the graph-cut criterion (Algorithm 2).
    SisCut,
    /// Gradient-vector-flow active shape model (Algorithm 1).
    GvfAsm,
    /// 2D TETRIS: the trained network's warp of the prior (Section 4.3.3); needs its weights
    /// ([`TableMatch::set_tetris`]).
    Tetris,
}

impl GuidedMethod {
    /// The three methods.
    pub const ALL: [GuidedMethod; 3] = [
        GuidedMethod::SisCut,
        GuidedMethod::GvfAsm,
        GuidedMethod::Tetris,
    ];

    /// The method's name on command lines and in results: `sis-cut`, `gvf-asm` or `tetris`.
    pub fn as_str(&self) -> &'static str {
        match self {
            GuidedMethod::SisCut => "sis-cut",
            GuidedMethod::GvfAsm => "gvf-asm",
            GuidedMethod::Tetris => "tetris",
        }
    }
}

/// A name that is not `sis-cut`, `gvf-asm` or `tetris`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownMethod;

impl core::str::FromStr for GuidedMethod {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        GuidedMethod::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or(UnknownMethod)
    }
}

/// The shape-guided loop and its stop rule: each round segments the chip guided by the current
/// prior, carries the segmentation's transform to the table match's axis and ends, matches
/// again, and keeps the new match only when it agrees with the current one and fits the width
/// profile no worse. Needs the core's `shape-guided` feature (on by default); without it no
/// loop runs whatever `method` says.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuidedLoopConfig {
    /// The segmentation method; None: the first table match is the pose.
    pub method: Option<GuidedMethod>,
    /// Most rounds (segmentations) a frame.
    pub max_rounds: u8,
    /// Stop when the segmentation moves the prior's box corners less than this, px.
    pub identity_px: f32,
    /// Reject a re-match whose tilt differs from the current one's by more, deg.
    pub max_tilt_change_deg: f32,
    /// Reject a re-match whose projected nose tip or tail base moved more, px.
    pub max_end_shift_px: f32,
    /// The segmentation methods' own tunables.
    #[cfg(feature = "shape-guided")]
    pub segmentation: ShapeGuidedConfig,
}

impl GuidedLoopConfig {
    /// The defaults: no loop; when a method is chosen, at most 2 rounds.
    pub const DEFAULT: GuidedLoopConfig = GuidedLoopConfig {
        method: None,
        max_rounds: 2,
        identity_px: 0.5,
        max_tilt_change_deg: 5.0,
        max_end_shift_px: 3.0,
        #[cfg(feature = "shape-guided")]
        segmentation: ShapeGuidedConfig::DEFAULT,
    };
}

impl Default for GuidedLoopConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The table-match stage's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MatchConfig {
    /// Bin width of the cylinder's cross-section, px.
    pub section_bin_px: f32,
    /// Margin kept from the nose shoulder and the fins when choosing the cylinder, in lengths.
    pub cylinder_margin: f32,
    /// The shortest cylinder stretch measured, px.
    pub min_cylinder_px: f32,
    /// Weight of each measured end in the match, in width bins.
    pub end_weight: f32,
    /// Without a range, where the sky beside the body is cluttered (detection follows its
    /// corridor), the shaded section's diameter stays within this factor of the silhouette's,
    /// which short stretches along the body read there
    /// ([`crate::extremes::cross_profile::ClutterWidth`]): the cylinder's stretch alone takes a
    /// cloud beside it into its width. On 21 simulated clutter clips without their range, Tz
    /// 0.80 times what it was (geometric mean of the medians), pitch and yaw 0.98-1.02.
    pub clutter_diameter_tolerance: f32,
    /// Draw the shape prior ([`TableMatch::prior`]) of every frame with a table match, for
    /// display and evaluation (the results do not depend on it). The shape-guided loop draws it
    /// whatever this says; the firmware, which displays nothing, turns it off.
    pub shape_prior: bool,
    /// The shape-guided loop.
    pub guided: GuidedLoopConfig,
}

impl MatchConfig {
    /// The defaults.
    pub const DEFAULT: MatchConfig = MatchConfig {
        section_bin_px: 0.2,
        cylinder_margin: 0.04,
        min_cylinder_px: 4.0,
        end_weight: 10.0,
        clutter_diameter_tolerance: 1.3,
        shape_prior: true,
        guided: GuidedLoopConfig::DEFAULT,
    };
}

impl Default for MatchConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The table-match stage's result: the hypothesis, and the table match where one was made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// The closed-form hypothesis the match started from.
    pub hypothesis: Hypothesis,
    /// The match kept (after the shape-guided loop, where it ran); None without a table or
    /// where nothing matched.
    pub matched: Option<MatchedPose>,
    /// The grey-level fit from the match, where it ran and converged inside its bounds.
    pub fitted: Option<GreyFitted>,
    /// Whether the sky beside the body is cluttered: the detection's sky follows the body's
    /// corridor ([`Background::follows_corridor`]), as it does among clouds and filaments.
    pub cluttered_sky: bool,
    /// Whether terrain enters the chip ([`Background::has_terrain`]).
    pub terrain: bool,
}

impl Measurement {
    /// Whether the body is seen among clutter: a cluttered sky beside it, or terrain in the
    /// chip. There the image range reads short for many frames together (a filament along the
    /// body, a ridge beside it widen the silhouette).
    pub fn among_clutter(&self) -> bool {
        self.cluttered_sky || self.terrain
    }

    /// Whether the frame's range comes from the image (no range sensor) among clutter: there
    /// its error is one the filters do not know
    /// ([`crate::uncertainty::UncertaintyConfig::cluttered_range_fraction`]).
    pub fn image_range_among_clutter(&self) -> bool {
        self.among_clutter() && self.hypothesis.sensor_range_m().is_none()
    }

    /// The slant range measured from the image, m: where the range was not given, the
    /// grey-level fit's scale's (the match's where the fit held it:
    /// `GreyFitConfig::wide_body_sigmas`), else the
    /// match's; where it was given, the apparent diameter's.
    pub fn image_range_m(&self) -> Option<f32> {
        if self.hypothesis.fixed_range_m.is_some() {
            return self.hypothesis.image_range_m;
        }
        self.fitted
            .map(|f| f.range_m)
            .or(self.matched.as_ref().map(|m| m.range_m))
            .or(self.hypothesis.image_range_m)
    }

    /// The pose at slant range `range_m` (the temporal stage's). With the range given, the
    /// match's. Without it, the mean of the match's and the closed form's: the match's tilt was
    /// fitted at the frame's own image scale, whose noise of a few per cent its length carries,
    /// while the closed form's ends do not depend on that scale, so their errors are partly
    /// independent (range unknown, the Table 1 test clip: pitch 0.148 -> 0.122, best yaw 1.76 ->
    /// 1.37 deg/km). Without a match, the closed form's.
    pub fn at_range(&self, camera: &Camera, model: &ProjectileModel, range_m: f32) -> ClosedForm {
        let closed = || self.hypothesis.at_range(camera, model, range_m);
        if let Some(fitted) = &self.fitted {
            let [nose, tail] = fitted.ends;
            return crate::closed_form::from_ends(nose, tail, camera, model.length_m, range_m);
        }
        match &self.matched {
            Some(m) if self.lengths_averaged() == 2 => {
                m.at_range(camera, model, range_m).mean(&closed())
            }
            Some(m) => m.at_range(camera, model, range_m),
            None => closed(),
        }
    }

    /// How many measurements of the apparent length [`Measurement::at_range`] averages: two
    /// (the match's and the closed form's) where the match ran and the range is not given, else
    /// one.
    pub fn lengths_averaged(&self) -> u8 {
        if self.fitted.is_none()
            && self.matched.is_some()
            && self.hypothesis.fixed_range_m.is_none()
        {
            2
        } else {
            1
        }
    }
}

/// The table-match stage and its buffers: the table (in flash on the firmware), the shape prior,
/// and the shape-guided segmentation's workspace and mask, all `MASK_WORDS` 32-bit words a mask.
pub struct TableMatch<const MASK_WORDS: usize = { crate::capacity::MASK_WORDS }> {
    table: Option<Table<'static>>,
    prior: BitMask<MASK_WORDS>,
    matched: Option<MatchedPose>,
    #[cfg(feature = "shape-guided")]
    guided: ShapeGuided,
    #[cfg(feature = "shape-guided")]
    guided_mask: BitMask<MASK_WORDS>,
    #[cfg(feature = "shape-guided")]
    outcome: Option<LoopOutcome>,
}

impl<const MASK_WORDS: usize> Default for TableMatch<MASK_WORDS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const MASK_WORDS: usize> TableMatch<MASK_WORDS> {
    /// A stage without a table: it matches nothing and draws no prior.
    pub const fn new() -> Self {
        TableMatch {
            table: None,
            prior: BitMask::new(),
            matched: None,
            #[cfg(feature = "shape-guided")]
            guided: ShapeGuided::new(),
            #[cfg(feature = "shape-guided")]
            guided_mask: BitMask::new(),
            #[cfg(feature = "shape-guided")]
            outcome: None,
        }
    }

    /// The stage matching against `table` (one built for the model: [`ProjectileModel::matches_table`]).
    pub const fn with_table(mut self, table: Table<'static>) -> Self {
        self.set_table(table);
        self
    }

    /// Matches against `table` from now on (one built for the model);
    /// in place, so that a stage inside a large pipeline is not moved.
    pub const fn set_table(&mut self, table: Table<'static>) {
        self.table = Some(table);
    }

    /// The shape-guided loop's TETRIS runs with `weights` from now on.
    #[cfg(feature = "shape-guided")]
    pub const fn set_tetris(&mut self, weights: crate::shape_guided::TetrisWeights<'static>) {
        self.guided.set_tetris(weights);
    }

    /// The shape prior of the last frame: the model's silhouette rendered at the matched pose
    /// (after the shape-guided loop, where it ran; at the grey-level fit's where the pipeline
    /// drew it again, [`TableMatch::redraw_prior`]), chip-sized (empty when nothing matched).
    pub fn prior(&self) -> &BitMask<MASK_WORDS> {
        &self.prior
    }

    /// The last frame's match kept, with its measurements.
    pub fn matched(&self) -> Option<&MatchedPose> {
        self.matched.as_ref()
    }

    /// The shape-guided segmentation of the last frame, chip-sized: around the prior at the
    /// grey-level fit's pose where the fit ran, else the loop's last round (the prior it started
    /// from where the method failed); empty where the loop did not run.
    #[cfg(feature = "shape-guided")]
    pub fn guided_mask(&self) -> &BitMask<MASK_WORDS> {
        &self.guided_mask
    }

    /// What the shape-guided loop did in the last frame (None where it did not run).
    #[cfg(feature = "shape-guided")]
    pub fn guided_loop(&self) -> Option<&LoopOutcome> {
        self.outcome.as_ref()
    }

    /// Forgets the last frame's prior, match and loop.
    pub fn clear(&mut self) {
        self.prior.clear();
        self.matched = None;
        #[cfg(feature = "shape-guided")]
        {
            self.guided_mask.clear();
            self.outcome = None;
        }
    }

    /// Matches the table to `chip` (with its sky model `background` and the body's contrast
    /// `polarity`) from `hypothesis`: the first match, its prior,
    /// and the shape-guided loop where configured.
    #[allow(clippy::too_many_arguments)]
    pub fn measure(
        &mut self,
        chip: &ChipView,
        background: &Background,
        polarity: BodyPolarity,
        hypothesis: &Hypothesis,
        camera: &Camera,
        model: &ProjectileModel,
        config: &MatchConfig,
    ) -> Measurement {
        self.clear();
        let input = MatchInput {
            chip,
            background,
            silhouette: &hypothesis.silhouette,
            polarity,
            origin: hypothesis.origin,
        };
        let range = hypothesis.fixed_range_m;
        let first = self.table.and_then(|table| {
            pose::match_pose(
                &input,
                &table,
                model,
                camera,
                &hypothesis.solution,
                range.map_or(pose::MatchScale::Free, pose::MatchScale::Range),
                config,
            )
            .ok()
        });
        let needs_prior = config.shape_prior || config.guided.method.is_some();
        let matched = first.map(|first| {
            if needs_prior {
                self.draw_prior(chip, &first);
            }
            self.guided_loop_from(&input, range, camera, model, config, first)
        });
        self.matched = matched;
        Measurement {
            hypothesis: *hypothesis,
            matched,
            fitted: None,
            cluttered_sky: background.follows_corridor(),
            terrain: background.has_terrain(),
        }
    }

    /// Without the `shape-guided` feature there is no loop: the first match is kept.
    #[cfg(not(feature = "shape-guided"))]
    #[allow(clippy::too_many_arguments)]
    fn guided_loop_from(
        &mut self,
        _input: &MatchInput,
        _range_m: Option<f32>,
        _camera: &Camera,
        _model: &ProjectileModel,
        _config: &MatchConfig,
        first: MatchedPose,
    ) -> MatchedPose {
        first
    }

    /// Draws the matched entry's silhouette into the prior mask.
    fn draw_prior(&mut self, chip: &ChipView, matched: &MatchedPose) {
        self.redraw_prior(chip, &matched.view, &matched.placement);
    }

    /// Draws the prior mask (again) as the table's entry nearest `view` at `placement` (chip
    /// px, px per body diameter): the match's pose, or one refined after it (the grey-level
    /// fit's), so that [`TableMatch::prior`] is the silhouette at the frame's final pose.
    pub fn redraw_prior(&mut self, chip: &ChipView, view: &View, placement: &Placement) {
        self.prior.clear();
        let Some(table) = &self.table else { return };
        let entry = table.entry_nearest(view);
        // A silhouette more than twice the chip's size is no prior for it, and filling takes
        // time quadratic in its size (a 2 m range drew for 3 s): not drawn.
        let (lo, hi) = entry.u_range();
        let side = chip.width().max(chip.height()) as f32;
        let fits = placement.px_per_unit * (hi - lo).max(1.0) <= 2.0 * side;
        if !fits {
            return;
        }
        if self.prior.reset(chip.width(), chip.height()).is_ok() {
            // The mask is an infallible draw target.
            let _ = render::draw_entry(&mut self.prior, &entry, placement);
        }
    }
}
