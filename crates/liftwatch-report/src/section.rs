//! One section of the report: a figure and the sentences that explain it, and the HTML
//! escaping both the figures' text and the page need.
//!
//! Both [`crate::figures`] (which builds sections) and [`crate::html`] (which lays them out)
//! import from here, so neither imports the other: lib → html → section, lib → figures →
//! section and plot.

use crate::plot::Figure;

/// One figure of the report and its text.
pub(crate) struct Section {
    /// The figure.
    pub figure: Figure,
    /// Heading in the report.
    pub heading: String,
    /// Paragraphs (already HTML: numbers and plain words only, no user text).
    pub text: Vec<String>,
}

/// Escapes text for HTML element content and attribute values.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_replaces_every_markup_character() {
        assert_eq!(
            escape("a<b>&\"c\" 'd'"),
            "a&lt;b&gt;&amp;&quot;c&quot; &#39;d&#39;"
        );
        assert_eq!(escape("λ = 0.5 m/s²"), "λ = 0.5 m/s²");
    }
}
