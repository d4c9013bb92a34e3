//! Time per 256 x 256 fixture chip of each core stage and of the whole frame (with the closed
//! form only, and with the table match of the bundled silhouette table), cycling through
//! the bundled `table1-test` clip (175 frames; `IMADE_BENCH_CLIP` names another clip). Times are
//! the benchmark thread's CPU time ([`common::cpu`]), one core.
//!
//! `cargo bench -p imade-tests --bench stages`; `tests/benches/compare-opencv` runs it beside
//! OpenCV's naive pipeline and prints the ratios.

// Shared with the worst-case benchmarks; not every item is used here.
#[allow(dead_code)]
mod common;

use common::cpu::ThreadCpuTime;
use common::{Fixture, Frame};
use criterion::{Criterion, criterion_group, criterion_main};
use imade_core::closed_form::Hypothesis;
use imade_core::extremes::{self, Silhouette};
use imade_core::segment::background::Background;
use imade_core::segment::label::{Labeler, Rect};
use imade_core::segment::{Expectation, Segmenter, Target};
use imade_core::table_match::TableMatch;
use imade_core::{Config, ImagePoint};
use std::hint::black_box;
use std::time::Duration;

/// One frame's intermediate results, computed once outside the timed loops.
struct Prepared<'a> {
    frame: &'a Frame,
    background: Background,
    target: Target,
    silhouette: Silhouette,
    hypothesis: Hypothesis,
}

fn prepare(fixture: &Fixture) -> Vec<Prepared<'_>> {
    let config = Config::DEFAULT;
    let mut segmenter: Box<Segmenter> = Box::default();
    fixture
        .frames
        .iter()
        .filter_map(|frame| {
            let chip = frame.view();
            let aim = ImagePoint::new(0.5 * chip.width() as f32, 0.5 * chip.height() as f32);
            let target = segmenter
                .detect(&chip, &config.detect, aim, &Expectation::NONE)
                .ok()?;
            let background = segmenter.background().clone();
            let (model, camera) = (&fixture.model, &fixture.camera);
            let silhouette = extremes::measure(
                &chip,
                &background,
                &target,
                model,
                &extremes::Prior::default(),
                &config.silhouette,
            )
            .ok()?;
            let hypothesis =
                Hypothesis::solve(&silhouette, frame.origin, camera, model, frame.range_m)?;
            Some(Prepared {
                frame,
                background,
                target,
                silhouette,
                hypothesis,
            })
        })
        .collect()
}

/// Cycles through `items`, one per call.
fn cycle<'a, T>(items: &'a [T]) -> impl FnMut() -> &'a T + 'a {
    let mut i = 0;
    move || {
        let item = &items[i % items.len()];
        i += 1;
        item
    }
}

fn stages(c: &mut Criterion<ThreadCpuTime>) {
    let fixture = common::load();
    let prepared = prepare(&fixture);
    eprintln!(
        "stages: {} frames from {}, {} measured",
        fixture.frames.len(),
        common::clip_dir().display(),
        prepared.len()
    );
    assert!(
        prepared.len() * 10 >= fixture.frames.len() * 9,
        "most fixture frames measure: {} of {}",
        prepared.len(),
        fixture.frames.len()
    );
    let config = Config::DEFAULT;
    let mut group = c.benchmark_group("stages");

    group.bench_function("background", |b| {
        let mut next = cycle(&fixture.frames);
        let mut background: Box<Background> = Box::default();
        b.iter(|| background.estimate(&black_box(next().view())));
    });

    group.bench_function("label", |b| {
        let mut next = cycle(&prepared);
        let mut labeler: Box<Labeler<4096, 512>> = Box::default();
        b.iter(|| {
            let p = next();
            let chip = p.frame.view();
            let threshold = config.detect.threshold_sigma * p.background.sigma();
            let whole = Rect {
                x0: 0,
                y0: 0,
                x1: chip.width() as u16,
                y1: chip.height() as u16,
            };
            let labelled = labeler.label(&black_box(chip), &p.background, whole, |r| {
                i8::from(r > threshold) - i8::from(r < -threshold)
            });
            black_box(labelled.map(|()| labeler.runs().len()))
        });
    });

    group.bench_function("detect", |b| {
        let mut next = cycle(&fixture.frames);
        let mut segmenter: Box<Segmenter> = Box::default();
        b.iter(|| {
            let chip = next().view();
            let aim = ImagePoint::new(0.5 * chip.width() as f32, 0.5 * chip.height() as f32);
            black_box(segmenter.detect(&black_box(chip), &config.detect, aim, &Expectation::NONE))
                .is_ok()
        });
    });

    group.bench_function("extremes", |b| {
        let mut next = cycle(&prepared);
        b.iter(|| {
            let p = next();
            black_box(extremes::measure(
                &black_box(p.frame.view()),
                &p.background,
                &p.target,
                &fixture.model,
                &extremes::Prior::default(),
                &config.silhouette,
            ))
        });
    });

    group.bench_function("closed_form", |b| {
        let mut next = cycle(&prepared);
        b.iter(|| {
            let p = next();
            black_box(Hypothesis::solve(
                black_box(&p.silhouette),
                p.frame.origin,
                &fixture.camera,
                &fixture.model,
                p.frame.range_m,
            ))
        });
    });

    if let Some(table) = fixture.table {
        group.bench_function("table_match", |b| {
            let mut next = cycle(&prepared);
            let mut stage: Box<TableMatch> = Box::new(TableMatch::new().with_table(table));
            // The match alone: no prior is drawn.
            let match_config = imade_core::MatchConfig {
                shape_prior: false,
                ..config.table_match
            };
            b.iter(|| {
                let p = next();
                let chip = black_box(p.frame.view());
                let (camera, model) = (&fixture.camera, &fixture.model);
                black_box(stage.measure(
                    &chip,
                    &p.background,
                    p.target.polarity,
                    &p.hypothesis,
                    camera,
                    model,
                    &match_config,
                ))
            });
        });
    }

    group.bench_function("flight_filter", flight_filter_update);

    // The whole frame with the closed form only, and with the table match where there is a table.
    let mut pipelines = vec![("frame", None)];
    pipelines.extend(fixture.table.map(|t| ("frame_table", Some(t))));
    for (name, table) in pipelines {
        group.bench_function(name, |b| common::bench_frames(b, &fixture, config, table));
    }

    group.finish();
}

/// One frame of the flight filter ([`imade_core::flight_filter`]): a ballistic flight seen
/// every 0.5 s from 1.2 km, the filter started on ten frames, then the eleventh taken (its sight
/// and image range) by a copy each iteration.
fn flight_filter_update(b: &mut criterion::Bencher<'_, ThreadCpuTime>) {
    use imade_core::flight_filter::{FlightFilter, FlightFilterConfig, RangeReading, Sight};
    let config = FlightFilterConfig::DEFAULT;
    let station = [-900.0, -600.0, 2.0];
    let frame = |k: u32| {
        let t = 0.5 * f64::from(k);
        let p = [80.0 * t, 100.0 * t, 500.0 + 60.0 * t - 4.903_325 * t * t];
        let d: Vec<f64> = p.iter().zip(&station).map(|(p, s)| p - s).collect();
        let range = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        let sight = Sight {
            station_enu_m: station,
            dir_enu: [d[0] / range, d[1] / range, d[2] / range],
            sd_rad: 1e-5,
        };
        let reading = RangeReading {
            range_m: range * 1.02,
            sd_m: 0.03 * range,
        };
        (t, sight, reading)
    };
    let mut started = FlightFilter::new();
    for k in 0..10 {
        let (t, sight, reading) = frame(k);
        started.update(t, &sight, reading, &config);
    }
    let (t, sight, reading) = frame(10);
    b.iter(|| {
        let mut filter = black_box(started.clone());
        black_box(filter.update(t, &sight, reading, &config))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .with_measurement(ThreadCpuTime::default())
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    targets = stages
}
criterion_main!(benches);
