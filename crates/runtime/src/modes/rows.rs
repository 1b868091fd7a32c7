//! A table of equally long rows of numbers kept in one buffer (row k is `values[k·w .. (k+1)·w]`): what a
//! run with modes records at every sample (the state, the reference y^(0 … R)), without one allocation per
//! sample.

use std::ops::Index;

/// Rows of `width` numbers each, in one buffer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rows {
    width: usize,
    rows: usize,
    values: Vec<f64>,
}

impl Rows {
    /// No rows yet, room for `capacity` of them.
    pub fn with_capacity(width: usize, capacity: usize) -> Rows {
        Rows {
            width,
            rows: 0,
            values: Vec::with_capacity(width * capacity),
        }
    }

    /// Append a row (`row.len()` must be the width).
    #[inline]
    pub fn push(&mut self, row: &[f64]) {
        assert_eq!(row.len(), self.width, "a row of another width");
        // A row is a few numbers: an element loop, not a `memcpy` call per row.
        self.values.extend(row.iter().copied());
        self.rows += 1;
    }

    /// The number of rows.
    pub fn len(&self) -> usize {
        self.rows
    }

    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }

    /// The number of values in a row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The rows in order.
    pub fn iter(&self) -> impl Iterator<Item = &[f64]> + '_ {
        (0..self.rows).map(|k| &self[k])
    }

    /// Column j: the j-th value of every row, in order.
    pub fn column(&self, j: usize) -> impl Iterator<Item = f64> + '_ {
        assert!(j < self.width, "column {j} of {}", self.width);
        self.values.iter().skip(j).step_by(self.width).copied()
    }

    /// Every column, in order: what [`Rows::column`] gives for each j, gathered by index into vectors of
    /// known length (no strided iterator).
    pub fn columns(&self) -> Vec<Vec<f64>> {
        let w = self.width;
        (0..w)
            .map(|j| (0..self.rows).map(|k| self.values[k * w + j]).collect())
            .collect()
    }

    /// Row k, if there is one.
    pub fn get(&self, k: usize) -> Option<&[f64]> {
        (k < self.rows).then(|| &self[k])
    }

    /// The first row, if any.
    pub fn first(&self) -> Option<&[f64]> {
        self.get(0)
    }

    /// The last row, if any.
    pub fn last(&self) -> Option<&[f64]> {
        self.rows.checked_sub(1).map(|k| &self[k])
    }
}

impl<'a> IntoIterator for &'a Rows {
    type Item = &'a [f64];
    type IntoIter = Box<dyn Iterator<Item = &'a [f64]> + 'a>;

    /// The rows in order (`for row in &rows`).
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

impl Index<usize> for Rows {
    type Output = [f64];

    /// Row k (panics beyond the last row).
    #[inline]
    fn index(&self, k: usize) -> &[f64] {
        assert!(k < self.rows, "row {k} of {}", self.rows);
        &self.values[k * self.width..(k + 1) * self.width]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_keep_their_values_and_order() {
        let mut r = Rows::with_capacity(2, 1);
        r.push(&[1.0, 2.0]);
        r.push(&[3.0, 4.0]);
        assert_eq!((r.len(), r.width()), (2, 2));
        assert_eq!(&r[1], &[3.0, 4.0]);
        assert_eq!(r.last(), Some(&[3.0, 4.0][..]));
        let all: Vec<&[f64]> = r.iter().collect();
        assert_eq!(all, vec![&[1.0, 2.0][..], &[3.0, 4.0][..]]);
        assert_eq!(r.column(1).collect::<Vec<f64>>(), vec![2.0, 4.0]);
        assert_eq!(r.columns(), vec![vec![1.0, 3.0], vec![2.0, 4.0]]);
        assert_eq!(Rows::with_capacity(0, 0).columns(), Vec::<Vec<f64>>::new());
        assert_eq!((r.first(), r.get(2)), (Some(&[1.0, 2.0][..]), None));
        assert_eq!((&r).into_iter().count(), 2);
        let mut empty = Rows::with_capacity(0, 0);
        empty.push(&[]);
        assert_eq!((empty.len(), &empty[0]), (1, &[][..]));
    }
}
