//! Writing the dataset CSV files (`docs/datasets.md`): the csv crate's writer (`,`
//! separated, `\n` after each record, quotes only where a field needs them) with every
//! number in its shortest form that reads back to the same `f64`, so that a file written
//! and read again gives the same values bit for bit.

use std::io::Write;

/// A dataset file being written, record by record.
pub(crate) struct CsvOut<W: Write> {
    w: csv::Writer<W>,
    cell: String,
}

impl<W: Write> CsvOut<W> {
    /// A writer whose first record is the header `names`.
    pub fn with_header<'a>(
        w: W,
        names: impl IntoIterator<Item = &'a str>,
    ) -> std::io::Result<Self> {
        let mut out = CsvOut {
            w: csv::WriterBuilder::new().from_writer(w),
            cell: String::with_capacity(32),
        };
        out.w.write_record(names)?;
        Ok(out)
    }

    /// A text field of the current record.
    pub fn text(&mut self, s: &str) -> std::io::Result<()> {
        Ok(self.w.write_field(s)?)
    }

    /// A number field of the current record, in its shortest round-trip form.
    pub fn number(&mut self, v: f64) -> std::io::Result<()> {
        use std::fmt::Write as _;
        self.cell.clear();
        let _ = write!(self.cell, "{v}");
        Ok(self.w.write_field(&self.cell)?)
    }

    /// Number fields of the current record.
    pub fn numbers(&mut self, vs: impl IntoIterator<Item = f64>) -> std::io::Result<()> {
        vs.into_iter().try_for_each(|v| self.number(v))
    }

    /// Ends the current record.
    pub fn end_record(&mut self) -> std::io::Result<()> {
        Ok(self.w.write_record(None::<&[u8]>)?)
    }

    /// Writes out what is buffered and flushes the destination.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_bit_for_bit_and_text_is_quoted_only_where_needed() {
        let mut buf = Vec::new();
        let mut out = CsvOut::with_header(&mut buf, ["t_s", "name"]).unwrap();
        let vs = [0.1 + 0.2, -1e-300, 123456.789, 5e-324];
        for v in vs {
            out.number(v).unwrap();
            out.text("a,b").unwrap();
            out.end_record().unwrap();
        }
        out.finish().unwrap();
        let text = String::from_utf8(buf).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("t_s,name"));
        for (line, v) in lines.zip(vs) {
            let (num, rest) = line.split_once(',').unwrap();
            assert_eq!(num.parse::<f64>().unwrap().to_bits(), v.to_bits());
            assert_eq!(rest, "\"a,b\"");
        }
        assert!(text.ends_with('\n') && !text.contains('\r'));
    }
}
