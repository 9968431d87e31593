//! Crosses and strips: the six faces placed as cells of one image, stored as they are except
//! the vertical cross's -Z, which is turned 180 degrees.

#![warn(missing_docs)]

use super::Kind;
use crate::cube::Faces;
use crate::image::Image;

/// Where one face sits: its cell (column, row) and whether it is turned 180 degrees.
#[derive(Clone, Copy, Debug)]
struct Cell {
    pub col: usize,
    pub row: usize,
    pub rotated: bool,
}

const fn c(col: usize, row: usize) -> Cell {
    Cell {
        col,
        row,
        rotated: false,
    }
}

/// The layouts made of cells: a type that can only be a cross or a strip, so laying faces out
/// and cutting them out need no check that the layout has cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cells {
    /// Horizontal cross, 4:3.
    Hcross,
    /// Vertical cross, 3:4 (-Z turned 180 degrees).
    Vcross,
    /// Horizontal strip, 6:1.
    Hstrip,
    /// Vertical strip, 1:6.
    Vstrip,
}

impl Cells {
    /// The layout these cells are.
    pub fn kind(self) -> Kind {
        match self {
            Cells::Hcross => Kind::Hcross,
            Cells::Vcross => Kind::Vcross,
            Cells::Hstrip => Kind::Hstrip,
            Cells::Vstrip => Kind::Vstrip,
        }
    }

    /// Grid size (columns, rows).
    pub fn grid(self) -> (usize, usize) {
        match self {
            Cells::Hcross => (4, 3),
            Cells::Vcross => (3, 4),
            Cells::Hstrip => (6, 1),
            Cells::Vstrip => (1, 6),
        }
    }

    /// The cell of each face in px nx py ny pz nz order.
    fn cells(self) -> [Cell; 6] {
        match self {
            Cells::Hcross => [c(2, 1), c(0, 1), c(1, 0), c(1, 2), c(1, 1), c(3, 1)],
            Cells::Vcross => [
                c(2, 1),
                c(0, 1),
                c(1, 0),
                c(1, 2),
                c(1, 1),
                Cell {
                    col: 1,
                    row: 3,
                    rotated: true,
                },
            ],
            Cells::Hstrip => std::array::from_fn(|i| c(i, 0)),
            Cells::Vstrip => std::array::from_fn(|i| c(0, i)),
        }
    }
}

/// Lays the faces out; unused cells are transparent black.
pub fn assemble(layout: Cells, faces: &Faces) -> Image {
    let ((cols, rows), cells) = (layout.grid(), layout.cells());
    let n = faces[0].width;
    let mut out = Image::new(cols * n, rows * n);
    for (face, cell) in faces.iter().zip(cells) {
        if cell.rotated {
            out.paste(&face.rotated_180(), cell.col * n, cell.row * n);
        } else {
            out.paste(face, cell.col * n, cell.row * n);
        }
    }
    out
}

/// Cuts the faces out of a cross or strip whose size fits the grid exactly.
pub fn extract(layout: Cells, img: &Image) -> Faces {
    let ((cols, _), cells) = (layout.grid(), layout.cells());
    let n = img.width / cols;
    // The six faces at once (each cut row by row in parallel too), into empty placeholders
    // (no allocation): the scope returns once every face is cut, so nothing is left to unwrap.
    let mut faces: Faces = std::array::from_fn(|_| Image {
        width: 0,
        height: 0,
        pixels: Vec::new(),
    });
    rayon::scope(|s| {
        for (slot, cell) in faces.iter_mut().zip(cells) {
            s.spawn(move |_| {
                let f = img.crop(cell.col * n, cell.row * n, n, n);
                *slot = if cell.rotated { f.rotated_180() } else { f };
            });
        }
    });
    faces
}
