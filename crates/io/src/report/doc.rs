//! A report as one structure (headings, paragraphs, tables, images, preformatted text), written
//! as markdown by [`Document::markdown`] and as a self-contained HTML page by
//! [`super::html::page`], so that the two never drift apart.

/// A table of text cells under a row of headers.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Table {
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows of cells (a row shorter than the headers is padded with empty cells when written).
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these headers and no row.
    pub fn new<S: Into<String>>(headers: impl IntoIterator<Item = S>) -> Self {
        Self { headers: headers.into_iter().map(Into::into).collect(), rows: Vec::new() }
    }

    /// Append a row.
    pub fn push<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows.push(cells.into_iter().map(Into::into).collect());
    }

    /// Columns: the headers' count, or the longest row's when it is longer.
    pub fn columns(&self) -> usize {
        self.rows.iter().map(Vec::len).fold(self.headers.len(), usize::max)
    }

    /// The cells of `row` padded to [`Table::columns`].
    pub fn padded<'a>(&'a self, row: &'a [String]) -> impl Iterator<Item = &'a str> + 'a {
        row.iter().map(String::as_str).chain(std::iter::repeat("")).take(self.columns())
    }

    /// The table in GitHub markdown (`|` in a cell escaped, an empty cell as `| |`).
    pub fn markdown(&self) -> String {
        let line = |cells: &mut dyn Iterator<Item = &str>| {
            let mut s = String::from("|");
            for c in cells {
                if c.is_empty() {
                    s += " |";
                } else {
                    s += &format!(" {} |", c.replace('|', "\\|").replace('\n', " "));
                }
            }
            s + "\n"
        };
        let mut out = line(&mut self.padded(&self.headers));
        out += &format!("|{}\n", "---|".repeat(self.columns()));
        for r in &self.rows {
            out += &line(&mut self.padded(r));
        }
        out
    }
}

/// A part of a report.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A heading of level 2 to 4 (the title is level 1).
    Heading(u8, String),
    /// A paragraph of plain text.
    Paragraph(String),
    /// A table.
    Table(Table),
    /// A PNG image: embedded in the HTML, linked in the markdown when `link` is given (a path
    /// relative to the markdown file), left out of the markdown otherwise.
    Image {
        /// Alternative text and caption.
        alt: String,
        /// Where the markdown finds the image file.
        link: Option<String>,
        /// The PNG bytes.
        png: Vec<u8>,
    },
    /// Preformatted text (a listing, a command's output).
    Pre(String),
}

/// A report: a title and its blocks in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Document {
    /// The title (the page's `<title>` and first heading).
    pub title: String,
    /// The blocks.
    pub blocks: Vec<Block>,
}

impl Document {
    /// An empty report titled `title`.
    pub fn new(title: impl Into<String>) -> Self {
        Self { title: title.into(), blocks: Vec::new() }
    }

    /// Append a heading of `level` (clamped to 2..=4).
    pub fn heading(&mut self, level: u8, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Heading(level.clamp(2, 4), text.into()));
        self
    }

    /// Append a paragraph.
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    /// Append a table.
    pub fn table(&mut self, table: Table) -> &mut Self {
        self.blocks.push(Block::Table(table));
        self
    }

    /// Append a PNG image with its markdown link (see [`Block::Image`]).
    pub fn image(&mut self, alt: impl Into<String>, link: Option<String>, png: Vec<u8>) -> &mut Self {
        self.blocks.push(Block::Image { alt: alt.into(), link, png });
        self
    }

    /// Append preformatted text.
    pub fn pre(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Pre(text.into()));
        self
    }

    /// Append the blocks of `other` (its title dropped), their image links prefixed by `prefix`
    /// (the folder of `other`'s files relative to this report's, `""` for the same one).
    pub fn append(&mut self, other: Document, prefix: &str) -> &mut Self {
        for b in other.blocks {
            self.blocks.push(match b {
                Block::Image { alt, link, png } => Block::Image { alt, link: link.map(|l| format!("{prefix}{l}")), png },
                b => b,
            });
        }
        self
    }

    /// The tables, in order.
    pub fn tables(&self) -> impl Iterator<Item = &Table> {
        self.blocks.iter().filter_map(|b| if let Block::Table(t) = b { Some(t) } else { None })
    }

    /// The report in markdown.
    pub fn markdown(&self) -> String {
        let mut out = format!("# {}\n", self.title);
        for b in &self.blocks {
            let text = match b {
                Block::Heading(level, text) => format!("{} {text}\n", "#".repeat(usize::from(*level))),
                Block::Paragraph(text) => format!("{text}\n"),
                Block::Table(t) => t.markdown(),
                Block::Image { alt, link: Some(link), .. } => format!("![{alt}]({link})\n"),
                Block::Image { link: None, .. } => continue,
                Block::Pre(text) => format!("```\n{}\n```\n", text.trim_end_matches('\n')),
            };
            out += "\n";
            out += &text;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_write_github_markdown() {
        let mut t = Table::new(["", "a|b", "c"]);
        t.push(["row", "1"]);
        t.push(["x", "2", "3", "extra"]);
        assert_eq!(t.columns(), 4);
        assert_eq!(t.markdown(), "| | a\\|b | c | |\n|---|---|---|---|\n| row | 1 | | |\n| x | 2 | 3 | extra |\n");
    }

    #[test]
    fn documents_write_markdown_with_linked_images_only() {
        let mut d = Document::new("run");
        d.heading(1, "Part").paragraph("text");
        let mut t = Table::new(["k", "v"]);
        t.push(["a", "1"]);
        d.table(t.clone()).image("linked", Some("p.png".into()), vec![1]).image("embedded only", None, vec![2]).pre("out\n");
        let mut sub = Document::new("sub");
        sub.image("plot", Some("error.png".into()), vec![3]);
        d.append(sub, "pbvs/");
        let md = d.markdown();
        assert_eq!(md, "# run\n\n## Part\n\ntext\n\n| k | v |\n|---|---|\n| a | 1 |\n\n![linked](p.png)\n\n```\nout\n```\n\n![plot](pbvs/error.png)\n");
        assert_eq!(d.tables().collect::<Vec<_>>(), vec![&t]);
    }
}
