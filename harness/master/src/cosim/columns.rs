//! The column store of a run's recording: one block of `table[column][row]`, filled a few
//! rows at a time.

/// The recorded values of a run, `table[column][row]`, column after column in one block.
///
/// One block, so that a campaign can hand it back ([`Plan::recycle`]) for the next run: a run
/// records tens of columns of 10⁴ rows (about 4 MB at 1 ms for 12 s), and memory the process
/// has not used yet is faulted in page by page (a vector per column cost about 1000 page
/// faults, a tenth of a short run's time on a virtual machine).
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    columns: usize,
    rows: usize,
    values: Vec<f64>,
}

impl Columns {
    /// `columns` columns of `rows` values in the memory of `block`. Old values are left in
    /// place: a run overwrites every cell (one that fails returns no table), so zeroing the
    /// megabytes again would be wasted.
    pub(crate) fn reusing(mut block: Vec<f64>, columns: usize, rows: usize) -> Self {
        assert!(rows > 0, "a table of recorded columns has at least one row");
        block.truncate(columns * rows);
        block.resize(columns * rows, 0.0);
        Columns {
            columns,
            rows,
            values: block,
        }
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.columns
    }

    pub fn is_empty(&self) -> bool {
        self.columns == 0
    }

    /// Number of rows (communication points) of every column.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The columns in order.
    pub fn iter(&self) -> std::slice::ChunksExact<'_, f64> {
        self.values.chunks_exact(self.rows)
    }

    /// Writes consecutive rows, given row after row in `rows_major` (`self.len()` values each),
    /// so that the last of them is row `last_row`.
    /// The memory of the table, for the next run ([`super::Plan::recycle`]).
    pub(super) fn into_block(self) -> Vec<f64> {
        self.values
    }

    fn write_rows(&mut self, last_row: usize, rows_major: &[f64]) {
        if self.columns == 0 {
            return;
        }
        let count = rows_major.len() / self.columns;
        let first_row = last_row + 1 - count;
        for (column, block) in self.values.chunks_exact_mut(self.rows).enumerate() {
            let cells = &mut block[first_row..=last_row];
            for (cell, row) in cells.iter_mut().zip(rows_major.chunks_exact(self.columns)) {
                *cell = row[column];
            }
        }
    }
}

impl std::ops::Index<usize> for Columns {
    type Output = [f64];

    fn index(&self, column: usize) -> &[f64] {
        assert!(
            column < self.columns,
            "column {column} of a table of {} columns",
            self.columns
        );
        &self.values[column * self.rows..(column + 1) * self.rows]
    }
}

impl<'a> IntoIterator for &'a Columns {
    type Item = &'a [f64];
    type IntoIter = std::slice::ChunksExact<'a, f64>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// A few recorded rows, row after row, before they go into the column-major table together.
///
/// Writing each communication point straight into tens of columns touches as many cache lines
/// 100 kB apart per step, about half a microsecond per step; a block of rows is written as
/// short contiguous runs per column instead.
pub(super) struct StagedRows {
    columns: usize,
    values: Vec<f64>,
    rows: usize,
}

impl StagedRows {
    pub(super) const CAPACITY: usize = 64;

    pub(super) fn new(columns: usize) -> Self {
        StagedRows {
            columns,
            values: vec![0.0; columns * Self::CAPACITY],
            rows: 0,
        }
    }

    /// The cells of the next row (to be filled).
    pub(super) fn next_row(&mut self) -> &mut [f64] {
        let start = self.rows * self.columns;
        self.rows += 1;
        &mut self.values[start..start + self.columns]
    }

    pub(super) fn is_full(&self) -> bool {
        self.rows == Self::CAPACITY
    }

    /// Moves the staged rows into `table`, the last of them being row `last_row`.
    pub(super) fn write_into(&mut self, table: &mut Columns, last_row: usize) {
        table.write_rows(last_row, &self.values[..self.rows * self.columns]);
        self.rows = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows staged in blocks land in the right cells, for a row count that is not a multiple
    /// of the block, also in a recycled block holding other values.
    #[test]
    fn staged_rows_fill_every_cell_of_the_table() {
        let (columns, rows) = (3, 2 * StagedRows::CAPACITY + 22);
        for old in [Vec::new(), vec![f64::NAN; columns * rows + 5]] {
            let mut table = Columns::reusing(old, columns, rows);
            let mut staged = StagedRows::new(columns);
            for n in 0..rows {
                for (c, cell) in staged.next_row().iter_mut().enumerate() {
                    *cell = (n * 10 + c) as f64;
                }
                if staged.is_full() || n == rows - 1 {
                    staged.write_into(&mut table, n);
                }
            }
            assert_eq!(table.len(), columns);
            assert_eq!(table.rows(), rows);
            for (c, column) in table.iter().enumerate() {
                let expected: Vec<f64> = (0..rows).map(|n| (n * 10 + c) as f64).collect();
                assert_eq!(column, expected.as_slice(), "column {c}");
            }
        }
    }
}
