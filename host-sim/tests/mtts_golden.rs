//! MTTS's outputs, bit for bit, on a fixed set of frames: the twelve standard scenes under each
//! prior, family members (seen, unseen and the thesis's corner, under the mode's prior, the
//! wrong one and none; members configured with the product's default design whatever their
//! lattice shows), and short sequences of frames through one pipeline (the narrowed lattice
//! search, the previous frame's decision). Each line holds T1, T2, the bound, the quality and
//! the lattice the frame left (period, exposed fraction, which target was hotter) as f32 bits.
//!
//! A change of the code that must not change a number (a refactoring) leaves
//! `tests/golden/mtts-separation.txt` as it is; a change that means to move numbers rewrites it
//! with `THERMORPH_WRITE_GOLDEN=1 cargo test --release -p host-sim --test mtts_golden`, and the
//! diff shows which frames moved.

use std::fmt::Write as _;

use host_sim::imaging::view::{Options, render, standard_scenes};
use host_sim::imaging::view_family::{Member, SEEN, UNSEEN, thesis};
use thermorph::mtts::{Config, Mtts, Output, Prior, Quality, Scratch};

const GOLDEN: &str = "tests/golden/mtts-separation.txt";

fn bits(x: Option<f32>) -> String {
    x.map_or("-".to_string(), |v| format!("{:08x}", v.to_bits()))
}

fn quality(q: Quality) -> &'static str {
    match q {
        Quality::Resolved => "resolved",
        Quality::Ambiguous => "ambiguous",
        Quality::Merged => "merged",
        Quality::Fallback => "fallback",
    }
}

fn line(out: &mut String, case: &str, o: &Output) {
    let g = &o.geometry;
    let hotter = match g.heater_hotter {
        None => "-",
        Some(true) => "heater",
        Some(false) => "surface",
    };
    let _ = writeln!(
        out,
        "{case} t1={} t2={} bound={} {} period={} exposed={} hotter={hotter}",
        bits(o.t1().map(|k| k.k())),
        bits(o.t2().map(|k| k.k())),
        bits(Some(o.bound.k())),
        quality(o.quality),
        bits(Some(g.period_px)),
        bits(Some(g.exposed)),
    );
}

fn priors() -> [(&'static str, Prior); 3] {
    [
        ("unknown", Prior::Unknown),
        ("heater", Prior::HeaterHotter),
        ("surface", Prior::SurfaceHotter),
    ]
}

/// The mode's prior for a member (the sign of its true gap) and the wrong one.
fn right_wrong(m: &Member) -> [(&'static str, Prior); 2] {
    if m.gap_k() >= 0.0 {
        [
            ("right", Prior::HeaterHotter),
            ("wrong", Prior::SurfaceHotter),
        ]
    } else {
        [
            ("right", Prior::SurfaceHotter),
            ("wrong", Prior::HeaterHotter),
        ]
    }
}

fn mtts(exposed_pct: u8, prior: Prior) -> Mtts {
    let mut m = Mtts::new(Config {
        exposed_pct,
        ..Config::default()
    })
    .unwrap();
    m.set_prior(prior);
    m
}

fn member_lines(out: &mut String, set: &str, m: &Member, scratch: &mut Scratch) {
    let img = m.render().image_k;
    let [right, wrong] = right_wrong(m);
    for (name, prior) in [right, wrong, ("none", Prior::Unknown)] {
        let o = mtts(m.design_exposed_pct, prior)
            .process(&img, scratch)
            .unwrap();
        line(out, &format!("{set} {} {name}", m.seed), &o);
    }
}

fn measure() -> String {
    let mut out = String::new();
    let scratch = &mut Scratch::new();
    for sc in standard_scenes() {
        let img = render(
            &sc.geometry,
            &sc.temps,
            &Options {
                noise_k: sc.noise_k,
                ..Options::default()
            },
        )
        .image_k;
        for (name, prior) in priors() {
            let mut p = mtts(Config::default().exposed_pct, prior);
            for frame in 0..3 {
                let o = p.process(&img, scratch).unwrap();
                line(&mut out, &format!("scene {} {name} #{frame}", sc.name), &o);
            }
        }
    }
    for seed in SEEN.start..SEEN.start + 80 {
        member_lines(&mut out, "seen", &Member::draw(seed), scratch);
    }
    for seed in UNSEEN.start..UNSEEN.start + 80 {
        member_lines(&mut out, "unseen", &Member::draw(seed), scratch);
    }
    for seed in UNSEEN.start..UNSEEN.start + 40 {
        member_lines(&mut out, "thesis", &thesis(seed), scratch);
    }
    // Members whatever their lattice, configured with the product's default design.
    for seed in UNSEEN.start..UNSEEN.start + 80 {
        let mut m = Member::draw(seed);
        m.design_exposed_pct = Config::default().exposed_pct;
        member_lines(&mut out, "default-design", &m, scratch);
    }
    // Sequences: the same member's frame four times through one pipeline, the mode's prior.
    for seed in UNSEEN.start..UNSEEN.start + 20 {
        let m = Member::draw(seed);
        let img = m.render().image_k;
        let [(_, right), _] = right_wrong(&m);
        let mut p = mtts(m.design_exposed_pct, right);
        for frame in 0..4 {
            let o = p.process(&img, scratch).unwrap();
            line(&mut out, &format!("sequence {seed} #{frame}"), &o);
        }
    }
    out
}

#[test]
fn mtts_outputs_are_the_golden_ones_bit_for_bit() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN);
    let now = measure();
    if std::env::var_os("THERMORPH_WRITE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &now).unwrap();
        return;
    }
    let golden = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (THERMORPH_WRITE_GOLDEN=1 writes it)",
            path.display()
        )
    });
    let moved: Vec<(&str, &str)> = golden
        .lines()
        .zip(now.lines())
        .filter(|(g, n)| g != n)
        .take(10)
        .collect();
    assert!(
        moved.is_empty() && golden.lines().count() == now.lines().count(),
        "{} of {} frames moved; the first:\n{}",
        golden
            .lines()
            .zip(now.lines())
            .filter(|(g, n)| g != n)
            .count(),
        golden.lines().count(),
        moved
            .iter()
            .map(|(g, n)| format!("  was {g}\n  now {n}"))
            .collect::<Vec<_>>()
            .join("\n")
    );
}
