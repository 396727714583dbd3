//! The CSV files mdas writes (`sweep.csv`, `tune.csv`, `frames.csv`,
//! `X.frames.csv`), written by the `csv` crate: a field is quoted only
//! where it must be (a comma, a double quote or a line break in it, RFC
//! 4180), so a label such as a `tune` configuration keeps its row.

/// The CSV text of `header` (its names separated by commas, none of which
/// needs quoting) and `rows`, each line ending in `\n`.
pub fn csv_text<R, F>(header: &str, rows: R) -> String
where
    R: IntoIterator<Item = Vec<F>>,
    F: AsRef<[u8]>,
{
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .quote_style(csv::QuoteStyle::Necessary)
        .from_writer(Vec::new());
    let names: Vec<&str> = header.split(',').collect();
    w.write_record(&names)
        .expect("a CSV record writes to memory");
    for row in rows {
        w.write_record(&row).expect("a CSV record writes to memory");
    }
    let bytes = w.into_inner().expect("a CSV writer flushes to memory");
    String::from_utf8(bytes).expect("CSV of UTF-8 fields is UTF-8")
}

#[cfg(test)]
mod tests {
    use super::csv_text;

    /// Plain fields are written as they are; a field with a comma or a
    /// double quote is quoted, and reads back as written.
    #[test]
    fn fields_are_quoted_only_where_needed_and_round_trip() {
        let label = r#"alpha=0.5, "fast" split=median"#;
        let text = csv_text(
            "rank,label,x",
            vec![
                vec!["1".to_string(), "plain label".into(), "0.25".into()],
                vec!["2".to_string(), label.into(), "".into()],
            ],
        );
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("rank,label,x"));
        assert_eq!(lines.next(), Some("1,plain label,0.25"));
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
        assert_eq!(rows.len(), 2);
        assert_eq!(&rows[1][1], label);
        assert_eq!(&rows[1][2], "");
        assert_eq!(rows[1].len(), 3);
    }
}
