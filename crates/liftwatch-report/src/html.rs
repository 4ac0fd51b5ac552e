//! `index.html`: the figures in order, each with its sentences; plain HTML and inline CSS, so
//! the directory can be opened, copied or mailed as it is.

use liftwatch::alarm::Level;
use liftwatch::verdict::Verdict;

use crate::section::{escape, Section};
use crate::{ReportInputs, APPENDIX};

/// Border colour of the verdict box per level (the figures' Okabe-Ito green, orange, red).
fn level_colour(level: Level) -> &'static str {
    match level {
        Level::Normal => "#009e73",
        Level::Advisory => "#e69f00",
        Level::Alarm => "#d55e00",
    }
}

/// The page's inline CSS: one column, readable line length, plain tables.
const STYLE: &str = "body{font-family:'DejaVu Sans',Helvetica,Arial,sans-serif;max-width:1240px;margin:2em auto;\
padding:0 1em;color:#222;line-height:1.5}h1{font-size:1.7em;margin-bottom:.2em}h2{font-size:1.3em;margin-top:2.2em;\
border-bottom:1px solid #ccc;padding-bottom:.2em}img{width:100%;height:auto;border:1px solid #e4e4e4}\
p.meta{color:#555}table{border-collapse:collapse;margin:.8em 0}td,th{border:1px solid #ccc;padding:.25em .7em;\
text-align:right}td:first-child,th:first-child,td:last-child,th:last-child{text-align:left}th{background:#f2f2f2}\
nav a{margin-right:1em}figure{margin:1em 0}figcaption{font-size:.9em;color:#555}\
.verdict{border-left:.6em solid;padding:.4em 1em;margin:1em 0;background:#fafafa}\
.verdict p.head{font-size:1.25em;font-weight:bold;margin:.3em 0}";

/// The page: title, data summary, a table of contents and one section per figure.
pub(crate) fn page(inp: &ReportInputs, sections: &[Section]) -> String {
    let m = inp.model;
    let e = &m.hybrid.elevator;
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(&format!(
        "<title>liftwatch report: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(inp.source)
    ));
    h.push_str(&format!(
        "<h1>liftwatch report: {}</h1>\n",
        escape(inp.source)
    ));
    h.push_str(&format!(
        "<p class=\"meta\">Elevator: rated load {} kg, rated speed {} m/s, {} floors. Model format version {}, \
         fitted on {} moving samples. Each figure is also saved as PNG beside its SVG.</p>\n",
        e.rated_load_kg, e.rated_speed_mps, e.floors, liftwatch::file::FORMAT_VERSION, m.summary.moving_samples
    ));
    let verdict = Verdict::new(m, inp.state);
    h.push_str(&format!(
        "<section class=\"verdict\" id=\"verdict\" style=\"border-color:{}\">\n<h2 style=\"margin-top:.3em\">Verdict</h2>\n",
        level_colour(verdict.level)
    ));
    for (i, line) in verdict.lines().iter().enumerate() {
        let class = if i == 0 { " class=\"head\"" } else { "" };
        h.push_str(&format!("<p{class}>{}</p>\n", escape(line)));
    }
    h.push_str("</section>\n");
    h.push_str("<nav>");
    for s in sections {
        h.push_str(&format!(
            "<a href=\"#{}\">{}</a> ",
            s.figure.name,
            escape(&s.heading)
        ));
    }
    h.push_str("</nav>\n");
    let mut in_appendix = false;
    for s in sections {
        let name = &s.figure.name;
        if !in_appendix && APPENDIX.contains(&name.as_str()) {
            in_appendix = true;
            h.push_str("<h2 id=\"appendix\">Appendix: the specialist figures</h2>\n<p>How the telemetry was prepared and how the model was trained: what a data scientist checks, not what maintenance acts on.</p>\n");
        }
        h.push_str(&format!("<h2 id=\"{name}\">{}</h2>\n", escape(&s.heading)));
        h.push_str(&format!(
            "<figure><img src=\"{name}.svg\" alt=\"{}\"><figcaption>{name}.svg (also <a href=\"{name}.png\">{name}.png</a>)</figcaption></figure>\n",
            escape(&s.heading)
        ));
        for p in &s.text {
            if p.starts_with("<table") || p.starts_with("Level changes") {
                h.push_str(&format!("<div>{p}</div>\n"));
            } else {
                h.push_str(&format!("<p>{p}</p>\n"));
            }
        }
    }
    h.push_str("</body>\n</html>\n");
    h
}
