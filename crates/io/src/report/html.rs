//! A [`Document`] as one self-contained HTML page: inline CSS, images as
//! `data:image/png;base64,...` URIs, no script and no network resource, so the page opens
//! anywhere (an archive, a CI artifact, a browser offline).

use base64::Engine as _;

use super::doc::{Block, Document, Table};

/// The page's style sheet.
const CSS: &str = "body{font-family:'DejaVu Sans',Helvetica,Arial,sans-serif;margin:24px auto;max-width:1240px;padding:0 16px;color:#1b1b1b;background:#fff;line-height:1.45}\
h1{border-bottom:2px solid #1f77b4;padding-bottom:4px}h2{margin-top:32px;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;margin:12px 0;font-size:14px}th,td{border:1px solid #bbb;padding:4px 10px;text-align:left}\
th{background:#e8eef6}tr:nth-child(even) td{background:#f6f6f6}td{font-variant-numeric:tabular-nums}\
figure{margin:12px 0}img{max-width:100%;height:auto;border:1px solid #ddd}figcaption{font-size:13px;color:#555}\
pre{background:#f4f4f4;padding:8px 12px;overflow-x:auto;font-size:13px}";

/// `text` with the HTML special characters `& < > " '` escaped (safe in text and in quoted
/// attribute values).
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out += "&amp;",
            '<' => out += "&lt;",
            '>' => out += "&gt;",
            '"' => out += "&quot;",
            '\'' => out += "&#39;",
            c => out.push(c),
        }
    }
    out
}

/// PNG bytes as a `data:image/png;base64,...` URI.
pub fn png_data_uri(png: &[u8]) -> String {
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png))
}

/// A table as an HTML `<table>` (headers in `<thead>`, cells escaped, short rows padded).
pub fn table(t: &Table) -> String {
    let row = |cells: &mut dyn Iterator<Item = &str>, tag: &str| {
        let inner: String = cells.map(|c| format!("<{tag}>{}</{tag}>", escape(c))).collect();
        format!("<tr>{inner}</tr>\n")
    };
    let mut out = format!("<table>\n<thead>\n{}</thead>\n<tbody>\n", row(&mut t.padded(&t.headers), "th"));
    for r in &t.rows {
        out += &row(&mut t.padded(r), "td");
    }
    out + "</tbody>\n</table>\n"
}

/// One block as HTML.
fn block(b: &Block) -> String {
    match b {
        Block::Heading(level, text) => format!("<h{level}>{}</h{level}>\n", escape(text)),
        Block::Paragraph(text) => format!("<p>{}</p>\n", escape(text)),
        Block::Table(t) => table(t),
        Block::Image { alt, png, .. } => {
            let alt = escape(alt);
            format!("<figure><img alt=\"{alt}\" src=\"{}\"><figcaption>{alt}</figcaption></figure>\n", png_data_uri(png))
        }
        Block::Pre(text) => format!("<pre>{}</pre>\n", escape(text)),
    }
}

/// The document as a complete HTML5 page (UTF-8).
pub fn page(doc: &Document) -> String {
    let title = escape(&doc.title);
    let mut out = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"generator\" content=\"synthcam {}\">\n<title>{title}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<h1>{title}</h1>\n",
        env!("CARGO_PKG_VERSION")
    );
    for b in &doc.blocks {
        out += &block(b);
    }
    out + "</body>\n</html>\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped() {
        assert_eq!(escape(r#"<a href="x">&'b'</a>"#), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;b&#39;&lt;/a&gt;");
        assert_eq!(escape("plain ±1 px"), "plain ±1 px");
        let mut d = Document::new("<script>alert(1)</script>");
        d.heading(2, "a & b").paragraph("x < y").pre("<pre>");
        let html = page(&d);
        assert!(!html.contains("<script>") && html.contains("<title>&lt;script&gt;alert(1)&lt;/script&gt;</title>"), "{html}");
        assert!(html.contains("<h2>a &amp; b</h2>") && html.contains("<p>x &lt; y</p>") && html.contains("<pre>&lt;pre&gt;</pre>"));
    }

    #[test]
    fn tables_have_a_head_and_padded_rows() {
        let mut t = Table::new(["name", "value \"px\""]);
        t.push(["<a>"]);
        t.push(["b", "2"]);
        let html = table(&t);
        assert_eq!(
            html,
            "<table>\n<thead>\n<tr><th>name</th><th>value &quot;px&quot;</th></tr>\n</thead>\n<tbody>\n<tr><td>&lt;a&gt;</td><td></td></tr>\n<tr><td>b</td><td>2</td></tr>\n</tbody>\n</table>\n"
        );
        assert_eq!(html.matches("<tr>").count(), 3);
    }

    #[test]
    fn images_round_trip_through_their_data_uri() {
        let img = image::RgbImage::from_fn(7, 5, |x, y| image::Rgb([x as u8 * 30, y as u8 * 40, 200]));
        let png = crate::report::plot::png(&img).expect("png");
        let uri = png_data_uri(&png);
        let b64 = uri.strip_prefix("data:image/png;base64,").expect("prefix");
        let back = base64::engine::general_purpose::STANDARD.decode(b64).expect("base64");
        assert_eq!(back, png);
        assert_eq!(image::load_from_memory(&back).expect("decode").to_rgb8(), img);
        let mut d = Document::new("t");
        d.image("a \"plot\"", None, png);
        let html = page(&d);
        assert!(html.contains(&format!("<img alt=\"a &quot;plot&quot;\" src=\"{uri}\">")), "{html}");
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
