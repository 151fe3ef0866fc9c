//! The target location grid of the CNN location experiment (docs/definitions.md §12): 25
//! locations on a 5x5 grid, location `5 i + j` an 8x8 target centred at pixel `(8 + 12 i,
//! 8 + 12 j)`. The application that inserts the targets and the report that draws them both
//! read the grid from here, so that a location label in `location.parquet` means one place.

/// Grid locations per side.
pub const GRID: usize = 5;
/// Number of locations (classes).
pub const LOCATIONS: usize = GRID * GRID;
/// Target side in pixels.
pub const TARGET: usize = 8;
/// Smallest image side that holds the grid (last centre 56, last target row 59).
pub const MIN_SIDE: usize = 60;

/// Centre `(row, column)` of location `label`.
pub fn centre(label: usize) -> (usize, usize) {
    (8 + 12 * (label / GRID), 8 + 12 * (label % GRID))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_grid_fits_its_smallest_side() {
        // The last target's last row and column, `centre - 4 + TARGET - 1`, inside MIN_SIDE.
        let (r, c) = super::centre(super::LOCATIONS - 1);
        assert_eq!((r, c), (56, 56));
        assert_eq!(r - 4 + super::TARGET, super::MIN_SIDE);
        assert_eq!(super::centre(7), (20, 32));
    }
}
