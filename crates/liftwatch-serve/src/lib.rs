//! Placeholder on the dashboard's branch until the server (branch `h-serve`) is merged: it
//! keeps the workspace building and checks that the dashboard's files exist. The server's
//! own `Cargo.toml` and `src/` replace this at the merge.

/// The dashboard's page, served at `/`.
pub const INDEX_HTML: &str = include_str!("../assets/index.html");
/// Its script, served at `/app.js`.
pub const APP_JS: &str = include_str!("../assets/app.js");
/// Its style sheet, served at `/style.css`.
pub const STYLE_CSS: &str = include_str!("../assets/style.css");
