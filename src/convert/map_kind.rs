//! What an environment map is stored as: a layout (one image, or six faces) or a cube-map
//! container. Layouts are geometry (`layout`); containers are file formats (`io`), so both
//! meet here, in the lowest layer above both, where `--to`, an input's kind and `info` name
//! them.

#![warn(missing_docs)]

use crate::io::Container;
use crate::layout::Kind;

/// What `--to` names and what an input was found to be: a layout or a container. Apart from
/// [`Kind`] so a container is never passed where only a layout makes sense (`--from`, the
/// crosses' cells); together here where either does.
///
/// ```
/// use cubeforge::{Container, Layout, MapKind};
///
/// let to: MapKind = Layout::Hcross.into();
/// assert_eq!((to.name(), to.is_cube()), ("hcross", false));
/// let to = MapKind::Container(Container::Ktx);
/// assert_eq!((to.name(), to.layout()), ("ktx", Layout::Faces));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(untagged)]
pub enum MapKind {
    /// A layout: a panorama, ball, cross, strip, octahedral map or six face images.
    Layout(Kind),
    /// A cube-map container file.
    Container(Container),
}

impl MapKind {
    /// Every map kind, the layouts first, in the order `--to` lists them.
    pub const ALL: [MapKind; 13] = [
        MapKind::Layout(Kind::Equirect),
        MapKind::Layout(Kind::Faces),
        MapKind::Layout(Kind::Hcross),
        MapKind::Layout(Kind::Vcross),
        MapKind::Layout(Kind::Hstrip),
        MapKind::Layout(Kind::Vstrip),
        MapKind::Layout(Kind::Sphere),
        MapKind::Layout(Kind::Angular),
        MapKind::Layout(Kind::Octahedral),
        MapKind::Container(Container::Ktx2),
        MapKind::Container(Container::Dds),
        MapKind::Container(Container::Ktx),
        MapKind::Container(Container::Env),
    ];

    /// The name on the command line (`--to`) and in `info`.
    pub fn name(self) -> &'static str {
        match self {
            MapKind::Layout(k) => k.name(),
            MapKind::Container(c) => c.name(),
        }
    }

    /// The layout the map has: a container holds faces.
    pub fn layout(self) -> Kind {
        match self {
            MapKind::Layout(k) => k,
            MapKind::Container(_) => Kind::Faces,
        }
    }

    /// The container, if the map is stored in one.
    pub fn container(self) -> Option<Container> {
        match self {
            MapKind::Container(c) => Some(c),
            MapKind::Layout(_) => None,
        }
    }

    /// Six faces, as images or in a container: a cube map, not a single image.
    pub fn is_cube(self) -> bool {
        self.layout() == Kind::Faces
    }
}

impl From<Kind> for MapKind {
    fn from(k: Kind) -> MapKind {
        MapKind::Layout(k)
    }
}

impl From<Container> for MapKind {
    fn from(c: Container) -> MapKind {
        MapKind::Container(c)
    }
}

/// `--to`'s values: the layouts' and the containers' own, so names and help stay theirs.
#[cfg(feature = "cli")]
impl clap::ValueEnum for MapKind {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        match self {
            MapKind::Layout(k) => clap::ValueEnum::to_possible_value(k),
            MapKind::Container(c) => clap::ValueEnum::to_possible_value(c),
        }
    }
}

#[cfg(all(test, feature = "cli"))]
mod tests {
    use super::*;
    use clap::ValueEnum;

    /// `--to` takes every layout's and container's name, each once, and each names itself.
    #[test]
    fn to_takes_each_name_once() {
        let names: Vec<&str> = MapKind::ALL.iter().map(|k| k.name()).collect();
        let mut unique = names.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!((names.len(), unique.len()), (13, 13));
        for k in MapKind::ALL {
            assert_eq!(MapKind::from_str(k.name(), false), Ok(k));
            assert!(k
                .to_possible_value()
                .and_then(|v| v.get_help().cloned())
                .is_some());
        }
        for c in Container::value_variants() {
            assert_eq!(c.format().container(), Some(*c));
        }
    }
}
