//! Crosses and strips: the six faces placed as cells of one image, stored as they are except
//! the vertical cross's -Z, which is turned 180 degrees.

#![warn(missing_docs)]

use super::Kind;
use crate::cube::Faces;
use crate::image::Image;

/// Where one face sits: its cell (column, row) and whether it is turned 180 degrees.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cell {
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

/// Grid size (columns, rows) and the cell of each face in px nx py ny pz nz order.
pub(crate) fn cells(kind: Kind) -> Option<((usize, usize), [Cell; 6])> {
    Some(match kind {
        Kind::Hcross => (
            (4, 3),
            [c(2, 1), c(0, 1), c(1, 0), c(1, 2), c(1, 1), c(3, 1)],
        ),
        Kind::Vcross => (
            (3, 4),
            [
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
        ),
        Kind::Hstrip => ((6, 1), std::array::from_fn(|i| c(i, 0))),
        Kind::Vstrip => ((1, 6), std::array::from_fn(|i| c(0, i))),
        _ => return None,
    })
}

/// Lays the faces out; unused cells are transparent black.
pub fn assemble(kind: Kind, faces: &Faces) -> Image {
    let ((cols, rows), cells) = cells(kind).expect("assemble needs a cross or strip kind");
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
pub fn extract(kind: Kind, img: &Image) -> Faces {
    let ((cols, _), cells) = cells(kind).expect("extract needs a cross or strip kind");
    let n = img.width / cols;
    // The six faces at once (each cut row by row in parallel too).
    let mut faces: [Option<Image>; 6] = Default::default();
    rayon::scope(|s| {
        for (slot, cell) in faces.iter_mut().zip(cells) {
            s.spawn(move |_| {
                let f = img.crop(cell.col * n, cell.row * n, n, n);
                *slot = Some(if cell.rotated { f.rotated_180() } else { f });
            });
        }
    });
    faces.map(|f| f.expect("every face cut"))
}
