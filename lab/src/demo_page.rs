//! The demo's `index.html`: every figure with its caption and every sound with
//! an audio player, in the seed's order, under the seed's section headings.
//! One self-contained page (no scripts, no outside links), relative links only,
//! so the directory can be moved, zipped or served as it is.

use std::fmt::Write as _;

/// One thing on the page.
#[derive(Clone, Debug, PartialEq)]
pub enum Entry {
    /// A section heading.
    Heading(String),
    /// A figure: a PNG chart or a GIF animation, with the numbers behind it.
    Figure {
        /// "Fig. 3" or "Figs. 15-17"
        label: String,
        caption: String,
        /// The image, relative to the page.
        image: String,
        /// The CSV(s) behind it, relative to the page.
        data: Vec<String>,
    },
    /// A sound, with its player.
    Sound { number: u8, caption: String, file: String },
}

impl Entry {
    /// Every file the entry links to.
    pub fn links(&self) -> Vec<&str> {
        match self {
            Entry::Heading(_) => Vec::new(),
            Entry::Figure { image, data, .. } => {
                std::iter::once(image.as_str()).chain(data.iter().map(String::as_str)).collect()
            }
            Entry::Sound { file, .. } => vec![file.as_str()],
        }
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The page.
pub fn page(title: &str, intro: &str, entries: &[Entry]) -> String {
    let mut html = String::new();
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{t}</title>\n<style>\n\
         body {{ font-family: sans-serif; max-width: 980px; margin: 2em auto; padding: 0 1em; color: #222; }}\n\
         figure {{ margin: 1.5em 0; }} figure img {{ max-width: 100%; border: 1px solid #ddd; }}\n\
         figcaption, .sound p {{ font-size: 0.95em; line-height: 1.4; }} .data {{ font-size: 0.85em; color: #555; }}\n\
         .sound {{ margin: 1.2em 0; padding: 0.6em 1em; background: #f4f6fa; border-left: 4px solid #4a6fa5; }}\n\
         </style>\n</head>\n<body>\n<h1>{t}</h1>\n<p>{i}</p>\n",
        t = escape(title),
        i = escape(intro)
    );
    for entry in entries {
        match entry {
            Entry::Heading(h) => {
                let _ = writeln!(html, "<h2>{}</h2>", escape(h));
            }
            Entry::Figure { label, caption, image, data } => {
                let links = data
                    .iter()
                    .map(|d| format!("<a href=\"{}\">{}</a>", escape(d), escape(d)))
                    .collect::<Vec<_>>()
                    .join(", ");
                let _ = writeln!(
                    html,
                    "<figure>\n<img src=\"{src}\" alt=\"{label}\">\n<figcaption><b>{label}.</b> {caption}{data}</figcaption>\n</figure>",
                    src = escape(image),
                    label = escape(label),
                    caption = escape(caption),
                    data = if links.is_empty() {
                        String::new()
                    } else {
                        format!(" <span class=\"data\">Numbers: {links}.</span>")
                    }
                );
            }
            Entry::Sound { number, caption, file } => {
                let _ = writeln!(
                    html,
                    "<div class=\"sound\">\n<p><b>Sound {number}.</b> {caption}</p>\n<audio controls preload=\"none\" src=\"{f}\"></audio> \
                     <a href=\"{f}\">{f}</a>\n</div>",
                    caption = escape(caption),
                    f = escape(file)
                );
            }
        }
    }
    html.push_str("</body>\n</html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_links_every_file_and_escapes_text() {
        let entries = vec![
            Entry::Heading("A & B".into()),
            Entry::Figure {
                label: "Fig. 3".into(),
                caption: "force <N>".into(),
                image: "fig03.png".into(),
                data: vec!["fig03.csv".into()],
            },
            Entry::Sound { number: 1, caption: "santoor".into(), file: "sound01.wav".into() },
        ];
        let html = page("Struck", "intro", &entries);
        assert!(html.contains("<h2>A &amp; B</h2>"));
        assert!(html.contains("force &lt;N&gt;"));
        for link in entries.iter().flat_map(Entry::links) {
            assert!(html.contains(&format!("\"{link}\"")), "{link}");
        }
        assert!(html.contains("<audio controls"));
        assert!(html.trim_end().ends_with("</html>"));
    }
}
