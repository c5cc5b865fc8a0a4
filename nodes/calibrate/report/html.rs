//! The page around the charts: sections, captions, escaping, and an inline style sheet
//! (no scripts, nothing fetched).

use std::fmt::Write;

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}\
h1{font-size:1.6em}h2{font-size:1.3em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}\
h3{font-size:1.05em;margin:.8em 0 .3em}\
table{border-collapse:collapse;margin:.4em 0 1em}td,th{border:1px solid #ddd;padding:.2em .6em;text-align:right}\
th{background:#f4f4f4}td.text{text-align:left}td.stamp{white-space:nowrap}\
.cameras{display:flex;flex-wrap:wrap;gap:1.5em}.cameras>figure,.cameras>div{flex:1 1 560px;margin:0}\
figure{margin:0 0 1em}figcaption{font-size:.9em;color:#555;margin-top:.3em}\
svg.chart{max-width:100%;height:auto}img.picture{max-width:100%;height:auto;image-rendering:auto}\
.rejected{color:#b3261e}";

/// An HTML page being assembled.
pub(crate) struct Page {
    body: String,
    title: String,
}

impl Page {
    /// An empty page with a title.
    pub fn new(title: &str) -> Self {
        Self {
            body: String::new(),
            title: title.to_owned(),
        }
    }

    /// Appends a section with a heading and HTML content.
    pub fn section(&mut self, heading: &str, content: &str) {
        let _ = write!(
            self.body,
            "<section><h2>{}</h2>\n{content}\n</section>\n",
            escape(heading)
        );
    }

    /// The whole document.
    pub fn finish(self) -> String {
        let title = escape(&self.title);
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n{}</body>\n</html>\n",
            self.body
        )
    }
}

/// Text made safe for HTML content and attribute values.
pub(crate) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
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

/// A paragraph of text.
pub(crate) fn paragraph(text: &str) -> String {
    format!("<p>{}</p>", escape(text))
}

/// A chart of one camera: a figure of class `kind` naming the camera, with `attributes`
/// (already escaped, each with a leading space), the SVG and a caption (HTML).
pub(crate) fn camera_figure(
    kind: &str,
    camera: &str,
    attributes: &str,
    svg: &str,
    caption: &str,
) -> String {
    format!(
        "<figure class=\"{kind}\" data-camera=\"{}\"{attributes}><h3>{}</h3>{svg}<figcaption>{caption}</figcaption></figure>\n",
        escape(camera),
        escape(camera)
    )
}
