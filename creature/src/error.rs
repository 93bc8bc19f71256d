//! Why a creature table, a shape, a part library, a kept monster or a contact
//! sheet is refused: the crate's errors, as data. Each message is the text users
//! read (written by hand, like the other crates' errors: `Display` and `Error`).

use mdg_vm::expr::CodeError;
use std::fmt;

/// Why a condition or probability expression is refused ([`crate::cond::verify`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CondError {
    /// The shared machine's own checks (stack discipline, skips, constants, an
    /// unknown variable).
    Code(CodeError),
    /// `parts(…)` of a kind the table does not have, at instruction `at`.
    UnknownKind { kind: u32, at: usize },
    /// A random function (`rand`, `randn`) at instruction `at`.
    RandomFunction { at: usize },
}

impl fmt::Display for CondError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CondError::Code(e) => write!(f, "{e}"),
            CondError::UnknownKind { kind, at } => write!(f, "unknown kind {kind} at {at}"),
            CondError::RandomFunction { at } => write!(f, "random function at {at}"),
        }
    }
}

impl std::error::Error for CondError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CondError::Code(e) => Some(e),
            _ => None,
        }
    }
}

impl From<CodeError> for CondError {
    fn from(e: CodeError) -> CondError {
        CondError::Code(e)
    }
}

/// Where in a creature table a problem is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Place {
    /// Embedded mesh `i`.
    Mesh(usize),
    /// A part, by name.
    Part(String),
    /// A slot (or the joint) of a part, by names.
    Slot { part: String, slot: String },
    /// An allelic family.
    Family,
    /// A regular creature, by name.
    Shape(String),
    /// A structure rule, by id.
    Rule(String),
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Place::Mesh(i) => write!(f, "mesh {i}"),
            Place::Part(p) => write!(f, "part `{p}`"),
            Place::Slot { part, slot } => write!(f, "part `{part}` slot `{slot}`"),
            Place::Family => write!(f, "family"),
            Place::Shape(s) => write!(f, "shape `{s}`"),
            Place::Rule(r) => write!(f, "rule `{r}`"),
        }
    }
}

/// What is wrong at a [`Place`] of a creature table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Problem {
    /// A NaN or infinite number.
    NonFinite,
    /// A triangle's vertex index past the mesh's positions.
    VertexOutOfRange,
    /// A kind index past the table's kinds.
    KindOutOfRange(u32),
    /// A category index past the table's categories.
    CategoryOutOfRange,
    /// A part's rule or mesh index past the bundle's rules or the table's meshes.
    GeometryOutOfRange,
    /// A part's scale that is not a positive number.
    BadScale,
    /// A part that is no torso and has no joint.
    NoJoint,
    /// A part that is no torso and has slots.
    SlotsOnNonTorso,
    /// A slot's size or spacing that is not a positive (spacing: non-negative) number.
    BadSizeOrSpacing,
    /// A slot whose normal and up are not unit vectors at right angles.
    NotOrthonormal,
    /// A slot's mirror or partner index past the part's slots.
    MirrorOutOfRange,
    /// Slot `slot` mirrors a slot that does not name it as its partner.
    MirrorUnpaired { slot: String },
    /// A regular creature's torso index past the table's parts.
    TorsoOutOfRange,
    /// A regular creature whose torso is not a torso part.
    NotATorso,
    /// An attachment's slot or part index out of range.
    AttachOutOfRange,
    /// An attachment's count that is 0 or over the limit.
    BadCount,
    /// A rule's `max` or `add` over the limit.
    CountOutOfRange,
    /// A rule's condition or probability expression is refused.
    Condition(CondError),
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::NonFinite => write!(f, "non-finite number"),
            Problem::VertexOutOfRange => write!(f, "vertex index out of range"),
            Problem::KindOutOfRange(k) => write!(f, "kind {k} out of range"),
            Problem::CategoryOutOfRange => write!(f, "category out of range"),
            Problem::GeometryOutOfRange => write!(f, "geometry index out of range"),
            Problem::BadScale => write!(f, "bad scale"),
            Problem::NoJoint => write!(f, "a non-torso part needs a joint"),
            Problem::SlotsOnNonTorso => write!(f, "only torsos have slots"),
            Problem::BadSizeOrSpacing => write!(f, "bad size or spacing"),
            Problem::NotOrthonormal => write!(f, "normal and up must be orthonormal"),
            Problem::MirrorOutOfRange => write!(f, "mirror slot out of range"),
            Problem::MirrorUnpaired { slot } => write!(f, "slot `{slot}` mirrors a slot that does not pair with it"),
            Problem::TorsoOutOfRange => write!(f, "torso part out of range"),
            Problem::NotATorso => write!(f, "the torso is not a torso part"),
            Problem::AttachOutOfRange => write!(f, "attach index out of range"),
            Problem::BadCount => write!(f, "bad count"),
            Problem::CountOutOfRange => write!(f, "count out of range"),
            Problem::Condition(e) => write!(f, "{e}"),
        }
    }
}

/// Why a decoded creature table does not verify ([`crate::CreatureTable::verify`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TableError {
    /// The table has no parts.
    NoParts,
    /// The table has no regular creatures.
    NoRegularCreatures,
    /// What is wrong, and where.
    At { place: Place, problem: Problem },
    /// An `evolve` setting past its limit.
    EvolveOutOfRange,
}

impl TableError {
    /// The problem `problem` at `place`.
    pub fn at(place: Place, problem: Problem) -> TableError {
        TableError::At { place, problem }
    }
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TableError::NoParts => write!(f, "no parts"),
            TableError::NoRegularCreatures => write!(f, "no regular creatures"),
            TableError::At { place, problem } => write!(f, "{place}: {problem}"),
            TableError::EvolveOutOfRange => write!(f, "evolve settings out of range"),
        }
    }
}

impl std::error::Error for TableError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            TableError::At { problem: Problem::Condition(e), .. } => Some(e),
            _ => None,
        }
    }
}

/// Why an abstract shape read from outside (a run's record) does not fit the
/// table ([`crate::shape::Shape::check`]); `sup` is the super-part's index (`S0`…).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShapeError {
    /// The shape has no super-parts.
    NoSuperParts,
    /// A super-part of a kind the table does not have.
    NoKind { sup: usize, kind: u32 },
    /// A super-part with no meta-parts, or a torso with more than one.
    MetaParts { sup: usize, n: usize },
    /// A meta-part whose part the table does not have.
    NoPart { sup: usize, part: u32 },
    /// A meta-part of another kind, with an id past the shape's, or without a joint
    /// where it hangs from a slot.
    MetaDoesNotFit { sup: usize, id: u32 },
    /// A super-part attached to no slot of a torso.
    NotOnATorsoSlot { sup: usize },
    /// The first super-part attached, or a later one attached to no earlier one.
    BadAttachment { sup: usize },
}

impl fmt::Display for ShapeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShapeError::NoSuperParts => write!(f, "no super-parts"),
            ShapeError::NoKind { sup, kind } => write!(f, "S{sup}: no type {kind}"),
            ShapeError::MetaParts { sup, n } => write!(f, "S{sup}: {n} meta-parts"),
            ShapeError::NoPart { sup, part } => write!(f, "S{sup}: no part {part}"),
            ShapeError::MetaDoesNotFit { sup, id } => write!(f, "S{sup}: meta-part {id} does not fit"),
            ShapeError::NotOnATorsoSlot { sup } => write!(f, "S{sup}: attached to no slot of a torso"),
            ShapeError::BadAttachment { sup } => write!(f, "S{sup}: bad attachment"),
        }
    }
}

impl std::error::Error for ShapeError {}

/// Why the part library cannot be built ([`crate::geometry::Library::build`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LibraryError {
    /// A mesh part whose mesh the table does not have.
    NoMesh { part: String },
    /// A part whose geometry has no triangles; `warning`: the first warning of
    /// its evaluation (a limit it hit), if any.
    NoTriangles { part: String, warning: Option<String> },
}

impl fmt::Display for LibraryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LibraryError::NoMesh { part } => write!(f, "part `{part}`: no mesh"),
            LibraryError::NoTriangles { part, warning: None } => {
                write!(f, "part `{part}`: its geometry has no triangles")
            }
            LibraryError::NoTriangles { part, warning: Some(w) } => {
                write!(f, "part `{part}`: its geometry has no triangles ({w})")
            }
        }
    }
}

impl std::error::Error for LibraryError {}

/// A kept monster that is not in the population ([`crate::evolve::Evolution::keep`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownMonster {
    /// The id asked for.
    pub id: String,
    /// The population's generation.
    pub generation: u32,
    /// The ids presented in that generation.
    pub presented: Vec<String>,
}

impl fmt::Display for UnknownMonster {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "no monster `{}` in generation {} (presented: {})",
            self.id,
            self.generation,
            self.presented.join(", ")
        )
    }
}

impl std::error::Error for UnknownMonster {}

/// Why a contact sheet cannot be made ([`crate::sheet::compose`], [`crate::sheet::decode_png`]).
#[derive(Debug)]
pub enum SheetError {
    /// A tile is not a PNG the decoder reads.
    Decode(png::DecodingError),
    /// A tile's pixels would not fit in memory.
    TooLarge,
    /// The decoder left a palette.
    Indexed,
    /// The decoded pixels are not width × height.
    SizeMismatch,
    /// No tiles to compose.
    NoTiles,
    /// Tiles of different sizes.
    TilesDiffer,
    /// The sheet could not be encoded.
    Encode(png::EncodingError),
}

impl fmt::Display for SheetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SheetError::Decode(e) => write!(f, "cannot decode PNG: {e}"),
            SheetError::TooLarge => write!(f, "PNG too large"),
            SheetError::Indexed => write!(f, "indexed PNG after expansion"),
            SheetError::SizeMismatch => write!(f, "PNG size mismatch"),
            SheetError::NoTiles => write!(f, "no tiles"),
            SheetError::TilesDiffer => write!(f, "tiles differ in size"),
            SheetError::Encode(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SheetError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SheetError::Decode(e) => Some(e),
            SheetError::Encode(e) => Some(e),
            _ => None,
        }
    }
}
