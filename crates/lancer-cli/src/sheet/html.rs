//! `lancer sheet -o sheet.html`: the sheet as one self-contained page: the title, the
//! description, and the grid as a table whose cells are the very PNGs `lancer render` would
//! write for them (embedded as `data:` URIs, so the page is one file to copy or mail), each with
//! its model in its tooltip and caption.

use std::fmt::Write as _;

use anyhow::Result;
use base64::Engine as _;

use super::Sheet;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The page of `sheet`.
pub(crate) fn page(sheet: &Sheet) -> Result<String> {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{title}</title>\n<style>{CSS}</style></head>\n<body>\n<h1>{title}</h1>\n",
        title = escape(&sheet.title)
    );
    if let Some(d) = sheet.description.as_deref().filter(|d| !d.trim().is_empty()) {
        let _ = writeln!(h, "<p>{}</p>", escape(d));
    }
    let _ = writeln!(
        h,
        "<p class=\"meta\">{} · scene {} · made by <code>lancer sheet</code></p>\n<table>",
        escape(&sheet.name),
        escape(&sheet.scene)
    );
    let columns = sheet.columns.len().max(1);
    if !sheet.columns.is_empty() {
        h.push_str("<tr>");
        if !sheet.rows.is_empty() {
            h.push_str("<th></th>");
        }
        for c in &sheet.columns {
            let _ = write!(h, "<th scope=\"col\">{}</th>", escape(c));
        }
        h.push_str("</tr>\n");
    }
    for (r, cells) in sheet.cells.chunks(columns).enumerate() {
        h.push_str("<tr>");
        let row = sheet.rows.get(r);
        if let Some(label) = row {
            let _ = write!(h, "<th scope=\"row\">{}</th>", escape(label));
        }
        for (c, cell) in cells.iter().enumerate() {
            let image = image::RgbImage::from_raw(cell.rect.width, cell.rect.height, cell.pixels.clone())
                .expect("a cell holds its pixels");
            let png = base64::engine::general_purpose::STANDARD.encode(super::png(&image)?);
            let alt = [sheet.columns.get(c), row].into_iter().flatten().cloned().collect::<Vec<_>>().join(", ");
            let _ = write!(
                h,
                "<td><figure><img src=\"data:image/png;base64,{png}\" width=\"{}\" height=\"{}\" alt=\"{}\" title=\"{}\">\
                 <figcaption>{}: {}</figcaption></figure></td>",
                cell.rect.width,
                cell.rect.height,
                escape(if alt.is_empty() { &sheet.title } else { &alt }),
                escape(&cell.model),
                escape(&cell.image),
                escape(&cell.model)
            );
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n</body></html>\n");
    Ok(h)
}

const CSS: &str = "body{font:16px/1.45 system-ui,sans-serif;margin:1.5em;background:#16181d;color:#e6e6e6}\
h1{margin:.2em 0}p{max-width:70em}.meta{color:#999;font-size:13px}code{color:#ffd27f}\
table{border-collapse:separate;border-spacing:.6em}td{vertical-align:top}th{font-weight:600}th[scope=row]{text-align:right}\
figure{margin:0}img{display:block;max-width:100%;height:auto;background:#000}\
figcaption{font-size:11px;color:#999;max-width:40em}";
