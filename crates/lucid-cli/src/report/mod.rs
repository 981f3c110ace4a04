//! Self-contained HTML reports (`lucid demo`, `lucid bench`): headings, paragraphs, tables,
//! SVG plots inlined in the page, and images saved beside it; written atomically.

pub mod images;
pub mod machine;
pub mod plot;

use std::fmt::Write as _;
use std::path::Path;

/// Escapes text for HTML.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// A labelled image beside the page (`path` relative to it).
#[derive(Clone, Debug)]
pub struct Figure {
    /// The caption.
    pub caption: String,
    /// Path relative to the report.
    pub path: String,
}

/// An HTML page under construction.
#[derive(Clone, Debug)]
pub struct Report {
    title: String,
    body: String,
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\
h1{font-size:1.6em}h2{margin-top:1.6em;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;margin:.8em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}\
th{background:#f0f0f0}td:first-child,th:first-child{text-align:left}\
.row{display:flex;flex-wrap:wrap;gap:.8em;margin:.6em 0}figure{margin:0;text-align:center}\
figure img{image-rendering:pixelated;width:160px;border:1px solid #ccc}figcaption{font-size:.8em}\
.plot{display:inline-block;margin:.4em}.note{color:#555;font-size:.9em}";

impl Report {
    /// An empty page.
    pub fn new(title: &str) -> Self {
        Self { title: title.into(), body: format!("<h1>{}</h1>\n", escape(title)) }
    }

    /// A section heading.
    pub fn heading(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(text));
        self
    }

    /// A small grey note.
    pub fn note(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p class=\"note\">{}</p>", escape(text));
        self
    }

    /// A table: a header row and rows of cells.
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) -> &mut Self {
        self.body.push_str("<table>\n<tr>");
        for h in header {
            let _ = write!(self.body, "<th>{}</th>", escape(h));
        }
        self.body.push_str("</tr>\n");
        for row in rows {
            self.body.push_str("<tr>");
            for c in row {
                let _ = write!(self.body, "<td>{}</td>", escape(c));
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</table>\n");
        self
    }

    /// SVG plots side by side (markup from [`plot`]).
    pub fn plots(&mut self, svgs: &[String]) -> &mut Self {
        self.body.push_str("<div class=\"row\">");
        for svg in svgs {
            let _ = write!(self.body, "<div class=\"plot\">{svg}</div>");
        }
        self.body.push_str("</div>\n");
        self
    }

    /// A row of images.
    pub fn figures(&mut self, figures: &[Figure]) -> &mut Self {
        self.body.push_str("<div class=\"row\">");
        for f in figures {
            let _ = write!(
                self.body,
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                escape(&f.path),
                escape(&f.caption),
                escape(&f.caption)
            );
        }
        self.body.push_str("</div>\n");
        self
    }

    /// The whole page.
    pub fn html(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\
             <style>{STYLE}</style></head>\n<body>\n{}</body></html>\n",
            escape(&self.title),
            self.body
        )
    }

    /// Writes the page to `path` (atomically).
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        crate::commands::write_text(path, &self.html())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_escapes_text_and_keeps_markup_of_plots() {
        let mut r = Report::new("a <b> & c");
        r.heading("h").table(&["x", "y"], &[vec!["1".into(), "<2>".into()]]).plots(&["<svg></svg>".into()]);
        let html = r.html();
        assert!(html.contains("<title>a &lt;b&gt; &amp; c</title>"));
        assert!(html.contains("<td>&lt;2&gt;</td>"));
        assert!(html.contains("<div class=\"plot\"><svg></svg></div>"));
        assert!(html.starts_with("<!DOCTYPE html>") && html.ends_with("</html>\n"));
    }
}
