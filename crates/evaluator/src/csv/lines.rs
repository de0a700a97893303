//! Line numbers of the records of a CSV text, for errors that name the line.

/// Line numbers (from 1) of the records of a CSV text, in order, for errors that name the line.
/// (The `csv` reader's own count lags a line behind after a CRLF line end.) Also used by the
/// CLI's batch input.
pub struct CsvLineNumbers<'a> {
    text: &'a [u8],
    /// Bytes counted so far, and the line they end on.
    byte: usize,
    line: usize,
}

impl<'a> CsvLineNumbers<'a> {
    /// Line numbers of the records of `text`.
    pub fn new(text: &'a str) -> Self {
        CsvLineNumbers {
            text: text.as_bytes(),
            byte: 0,
            line: 1,
        }
    }

    /// The line of the record the reader places at `byte`: the first line with content from
    /// there (the position may be at the line end before it). Positions must not decrease.
    pub fn at(&mut self, byte: u64) -> usize {
        let mut end = usize::try_from(byte).map_or(self.text.len(), |b| b.min(self.text.len()));
        while self
            .text
            .get(end)
            .is_some_and(|b| matches!(b, b'\r' | b'\n'))
        {
            end += 1;
        }
        if end > self.byte {
            self.line += self.text[self.byte..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.byte = end;
        }
        self.line
    }
}
