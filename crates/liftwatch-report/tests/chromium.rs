//! The report as a browser shows it: a small simulated report rendered by headless Chromium,
//! its DOM checked (the verdict comes before any figure) and screenshots kept as artefacts
//! under `target/screenshots/` (`report-top.png`: the first screen, `report-full.png`: the
//! whole page). Skipped, saying why, on a machine without `chromium` (`.ci/run` installs it).

use liftwatch::sample::DAY_S;
use std::path::{Path, PathBuf};
use std::process::Command;

use liftwatch::model::TrainConfig;
use liftwatch::monitor::Analysis;
use liftwatch::sim::{simulate, SimConfig};
use liftwatch::Elevator;
use liftwatch_report::{write_report, ReportInputs};

/// Width of the screenshots (px): a laptop screen.
const WIDTH: u32 = 1280;

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|name| {
            let ok = Command::new(name)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success());
            ok.then(|| PathBuf::from(name))
        })
}

/// Runs headless Chromium on `url` with `args`; returns stdout.
fn headless(bin: &Path, args: &[String], url: &str) -> String {
    let out = Command::new(bin)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .args(args)
        .arg(url)
        .output()
        .expect("chromium runs");
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Width and height of a PNG from its IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).expect("the screenshot exists");
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{} is a PNG", path.display());
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

#[test]
fn the_report_renders_in_chromium_with_the_verdict_first() {
    let Some(bin) = chromium() else {
        eprintln!("skipped: no chromium on this machine (apt-get install -y chromium)");
        return;
    };
    let elevator = Elevator::new(1000.0, 1.6, 16);
    let mut sim = SimConfig::new(elevator.clone(), 0.5, 11);
    sim.start_s = 20_510.0 * DAY_S; // 2026-02-26 UTC: the axes and the verdict show dates
    let series = simulate(&sim).expect("valid settings").aligned();
    let cfg = TrainConfig {
        epochs: 60,
        log_every: 10,
        ..TrainConfig::default()
    };
    let model = liftwatch::fit::fit(&series, &elevator, &cfg, &mut |_| {})
        .expect("half a simulated day fits")
        .model;
    let analysis = Analysis::run(&model, &series);
    let target = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("the tmp dir lies in target/")
        .join("screenshots");
    let dir = target.join("report");
    let _ = std::fs::remove_dir_all(&dir);
    write_report(
        &dir,
        &ReportInputs::new(&analysis, &model, &series, "simulated half day"),
    )
    .expect("the report is written");
    let url = format!("file://{}", dir.join("index.html").display());

    // The DOM after loading: the verdict is the first section, before any figure.
    let dom = headless(&bin, &["--dump-dom".into()], &url);
    let verdict = dom.find("id=\"verdict\"").expect("a verdict section");
    let figure = dom.find("<img").expect("figures");
    assert!(verdict < figure, "the verdict comes before the figures");
    assert!(
        dom.contains("NORMAL (as of 2026-02-26"),
        "the verdict's headline, dated"
    );

    for (name, height) in [("report-top.png", 2000), ("report-full.png", 16000)] {
        let png = target.join(name);
        let _ = std::fs::remove_file(&png);
        headless(
            &bin,
            &[
                format!("--screenshot={}", png.display()),
                format!("--window-size={WIDTH},{height}"),
            ],
            &url,
        );
        assert_eq!(png_size(&png), (WIDTH, height), "{}", png.display());
        let bytes = std::fs::metadata(&png).map(|m| m.len()).unwrap_or(0);
        assert!(
            bytes > 50_000,
            "{} holds {bytes} bytes: a blank page?",
            png.display()
        );
        eprintln!("screenshot: {}", png.display());
    }
}
