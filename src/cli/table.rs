//! Markdown tables, as README and docs/performance.md show them: the peers benchmark's and
//! `report`'s, through this one writer.

/// A table: a header and rows of cells, already formatted.
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table of these column headers and no rows.
    pub fn new(header: &[&str]) -> Table {
        Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Adds a row; it must have a cell per column.
    pub fn row(&mut self, cells: Vec<String>) {
        assert_eq!(cells.len(), self.header.len(), "a cell per column");
        self.rows.push(cells);
    }

    /// The table as GitHub-flavoured Markdown, one line per row.
    pub fn markdown(&self) -> String {
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        let mut t = line(&self.header);
        t += &format!("|{}\n", "---|".repeat(self.header.len()));
        for r in &self.rows {
            t += &line(r);
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_has_a_rule_under_the_header() {
        let mut t = Table::new(&["a", "b"]);
        t.row(vec!["1".into(), "x y".into()]);
        assert_eq!(t.markdown(), "| a | b |\n|---|---|\n| 1 | x y |\n");
    }
}
