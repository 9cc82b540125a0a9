//! PLY (Stanford polygon format): ascii, binary_little_endian and
//! binary_big_endian. Vertices come from the `x`, `y`, `z` properties of
//! element `vertex`, faces from the list property `vertex_indices` (or
//! `vertex_index`) of element `face`, fan-triangulated; every other element
//! and property is read by its type and skipped.

use glam::Vec3;

use super::{FaceSource, Faces, ParseError, finite};
use crate::TriangleMesh;

const TYPES_HINT: &str = "PLY property types are char, uchar, short, ushort, int, uint, float and \
     double (or int8, uint8, int16, uint16, int32, uint32, float32, float64)";
const TRUNCATED_HINT: &str = "the file is truncated or damaged; export it again";

pub(super) fn parse(bytes: &[u8]) -> Result<TriangleMesh, ParseError> {
    let header = Header::parse(bytes)?;
    let roles = Roles::of(&header.elements)?;
    let mut body = match header.encoding {
        Encoding::Ascii => Body::Ascii {
            text: &bytes[header.body_start..],
            pos: 0,
            line: header.lines + 1,
        },
        Encoding::Binary { big_endian } => Body::Binary {
            data: &bytes[header.body_start..],
            pos: 0,
            big_endian,
        },
    };
    let mut mesh = MeshData::default();
    for (e, element) in header.elements.iter().enumerate() {
        for instance in 0..element.count {
            let place = Place { element, instance };
            if Some(e) == roles.vertex {
                mesh.vertices.push(read_vertex(&mut body, &roles, place)?);
            } else if Some(e) == roles.face {
                read_face(&mut body, &roles, place, &mut mesh)?;
            } else {
                skip_instance(&mut body, place)?;
            }
        }
    }
    let hint = |n: usize| {
        format!(
            "PLY vertex indices run from 0 to {}; fix or remove the face",
            n - 1
        )
    };
    mesh.faces.check_indices(mesh.vertices.len(), 0, hint)?;
    mesh.faces.into_mesh(mesh.vertices)
}

#[derive(Default)]
struct MeshData {
    vertices: Vec<Vec3>,
    faces: Faces,
    polygon: Vec<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big_endian: bool },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn named(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes one value from exactly `self.size()` bytes.
    fn decode(self, bytes: &[u8], big_endian: bool) -> f64 {
        let mut raw = [0u8; 8];
        raw[..bytes.len()].copy_from_slice(bytes);
        if big_endian {
            raw[..bytes.len()].reverse();
        }
        let [b0, b1, b2, b3, ..] = raw;
        match self {
            Scalar::I8 => f64::from(b0 as i8),
            Scalar::U8 => f64::from(b0),
            Scalar::I16 => f64::from(i16::from_le_bytes([b0, b1])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b0, b1])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b0, b1, b2, b3])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b0, b1, b2, b3])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b0, b1, b2, b3])),
            Scalar::F64 => f64::from_le_bytes(raw),
        }
    }
}

#[derive(Debug)]
enum Property {
    Scalar {
        ty: Scalar,
        name: String,
    },
    List {
        count: Scalar,
        item: Scalar,
        name: String,
    },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar { name, .. } | Property::List { name, .. } => name,
        }
    }
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    line: usize,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    body_start: usize,
    lines: usize,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header, ParseError> {
        let mut reader = HeaderReader::default();
        while let Some(text) = reader.next_line(bytes)? {
            let tokens: Vec<&str> = text.split_whitespace().collect();
            if reader.line == 1 {
                expect_magic(&tokens)?;
            } else {
                reader.read(&tokens)?;
            }
        }
        reader.finish()
    }
}

/// The header as read so far.
#[derive(Default)]
struct HeaderReader {
    encoding: Option<Encoding>,
    elements: Vec<Element>,
    pos: usize,
    line: usize,
    ended: bool,
}

impl HeaderReader {
    /// The next header line, `None` after `end_header`.
    fn next_line(&mut self, bytes: &[u8]) -> Result<Option<String>, ParseError> {
        if self.ended {
            return Ok(None);
        }
        let rest = &bytes[self.pos..];
        let length = rest.iter().position(|&b| b == b'\n').ok_or_else(|| {
            ParseError::new(
                Some(self.line.max(1)),
                "the PLY header has no end_header line",
                "the file is truncated or not a PLY file; export it again",
            )
        })?;
        self.pos += length + 1;
        self.line += 1;
        Ok(Some(String::from_utf8_lossy(&rest[..length]).into_owned()))
    }

    fn read(&mut self, tokens: &[&str]) -> Result<(), ParseError> {
        let line = self.line;
        match tokens {
            [] | ["comment" | "obj_info", ..] => {}
            ["format", rest @ ..] => self.encoding = Some(parse_format(rest, line)?),
            ["element", rest @ ..] => self.elements.push(parse_element(rest, line)?),
            ["property", rest @ ..] => {
                let property = parse_property(rest, line)?;
                let element = self
                    .elements
                    .last_mut()
                    .ok_or_else(|| orphan_property(line))?;
                element.properties.push(property);
            }
            ["end_header"] => self.ended = true,
            [other, ..] => {
                return Err(ParseError::new(
                    Some(line),
                    format!("unexpected '{}' in the PLY header", shorten(other)),
                    "PLY header lines start with format, element, property, comment, obj_info or end_header",
                ));
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<Header, ParseError> {
        let encoding = self.encoding.ok_or_else(|| {
            ParseError::new(
                Some(self.line),
                "the PLY header has no format line",
                "add `format ascii 1.0` (or the binary format) after `ply`",
            )
        })?;
        Ok(Header {
            encoding,
            elements: self.elements,
            body_start: self.pos,
            lines: self.line,
        })
    }
}

fn expect_magic(tokens: &[&str]) -> Result<(), ParseError> {
    if tokens == ["ply"] {
        return Ok(());
    }
    Err(ParseError::new(
        Some(1),
        "this is not a PLY file: the first line must be 'ply'",
        "check that the file really is a PLY file, or give it the right extension",
    ))
}

fn parse_format(rest: &[&str], line: usize) -> Result<Encoding, ParseError> {
    match rest.first().copied() {
        Some("ascii") => Ok(Encoding::Ascii),
        Some("binary_little_endian") => Ok(Encoding::Binary { big_endian: false }),
        Some("binary_big_endian") => Ok(Encoding::Binary { big_endian: true }),
        other => Err(ParseError::new(
            Some(line),
            format!(
                "unknown PLY format '{}'",
                shorten(other.unwrap_or_default())
            ),
            "use `format ascii 1.0`, `format binary_little_endian 1.0` or `format binary_big_endian 1.0`",
        )),
    }
}

fn parse_element(rest: &[&str], line: usize) -> Result<Element, ParseError> {
    let malformed = || {
        ParseError::new(
            Some(line),
            "malformed element line",
            "write elements as `element <name> <count>`, e.g. `element vertex 8`",
        )
    };
    let [name, count] = rest else {
        return Err(malformed());
    };
    let count = count.parse().map_err(|_| malformed())?;
    Ok(Element {
        name: name.to_string(),
        count,
        properties: Vec::new(),
        line,
    })
}

fn parse_property(rest: &[&str], line: usize) -> Result<Property, ParseError> {
    let ty = |name: &str| {
        Scalar::named(name).ok_or_else(|| {
            ParseError::new(
                Some(line),
                format!("unknown property type '{}'", shorten(name)),
                TYPES_HINT,
            )
        })
    };
    match rest {
        ["list", count, item, name] => {
            let count = ty(count)?;
            if !count.is_integer() {
                return Err(ParseError::new(
                    Some(line),
                    format!("the list '{name}' has a floating-point count type"),
                    "list counts must be an integer type such as uchar or int",
                ));
            }
            Ok(Property::List {
                count,
                item: ty(item)?,
                name: name.to_string(),
            })
        }
        [scalar, name] if *scalar != "list" => Ok(Property::Scalar {
            ty: ty(scalar)?,
            name: name.to_string(),
        }),
        _ => Err(ParseError::new(
            Some(line),
            "malformed property line",
            "write properties as `property <type> <name>` or `property list <count type> <item type> <name>`",
        )),
    }
}

fn orphan_property(line: usize) -> ParseError {
    ParseError::new(
        Some(line),
        "a property comes before any element",
        "put `element <name> <count>` before its properties",
    )
}

fn shorten(token: &str) -> String {
    token.chars().take(40).collect()
}

/// Which element and properties hold the vertices and faces.
struct Roles {
    vertex: Option<usize>,
    xyz: [usize; 3],
    face: Option<usize>,
    indices: usize,
}

impl Roles {
    fn of(elements: &[Element]) -> Result<Roles, ParseError> {
        let find = |name: &str| elements.iter().position(|e| e.name == name);
        let mut roles = Roles {
            vertex: find("vertex"),
            xyz: [0; 3],
            face: find("face"),
            indices: 0,
        };
        if let Some(v) = roles.vertex {
            for (slot, axis) in roles.xyz.iter_mut().zip(["x", "y", "z"]) {
                *slot = scalar_property(&elements[v], axis)?;
            }
        }
        if let Some(f) = roles.face {
            roles.indices = index_list(&elements[f])?;
        }
        Ok(roles)
    }
}

fn scalar_property(element: &Element, name: &str) -> Result<usize, ParseError> {
    element
        .properties
        .iter()
        .position(|p| matches!(p, Property::Scalar { name: n, .. } if n == name))
        .ok_or_else(|| {
            ParseError::new(
                Some(element.line),
                format!("the vertex element has no scalar property '{name}'"),
                "give vertices `property float x`, `property float y` and `property float z`",
            )
        })
}

fn index_list(element: &Element) -> Result<usize, ParseError> {
    element
        .properties
        .iter()
        .position(|p| {
            matches!(p, Property::List { item, .. } if item.is_integer())
                && matches!(p.name(), "vertex_indices" | "vertex_index")
        })
        .ok_or_else(|| {
            ParseError::new(
                Some(element.line),
                "the face element has no integer list 'vertex_indices' (or 'vertex_index')",
                "describe faces as `property list uchar int vertex_indices`",
            )
        })
}

/// Which instance of which element is being read, for messages.
#[derive(Clone, Copy)]
struct Place<'a> {
    element: &'a Element,
    instance: usize,
}

impl Place<'_> {
    fn describe(&self) -> String {
        format!(
            "{} {} (counting from 0, of {})",
            self.element.name, self.instance, self.element.count
        )
    }
}

fn read_vertex(body: &mut Body, roles: &Roles, place: Place) -> Result<Vec3, ParseError> {
    let line = body.line();
    let mut xyz = [0.0f32; 3];
    for (p, property) in place.element.properties.iter().enumerate() {
        match property {
            Property::Scalar { ty, .. } => {
                let value = body.read(*ty, place)?;
                if let Some(axis) = roles.xyz.iter().position(|&a| a == p) {
                    let what = || format!("vertex {}", place.instance);
                    xyz[axis] = finite(value as f32, line, &what)?;
                }
            }
            Property::List { count, item, .. } => skip_list(body, *count, *item, place)?,
        }
    }
    Ok(Vec3::from_array(xyz))
}

fn read_face(
    body: &mut Body,
    roles: &Roles,
    place: Place,
    mesh: &mut MeshData,
) -> Result<(), ParseError> {
    let source = FaceSource {
        face: place.instance,
        line: body.line(),
    };
    for (p, property) in place.element.properties.iter().enumerate() {
        match property {
            Property::List { count, item, .. } if p == roles.indices => {
                let n = body.read_count(*count, place)?;
                mesh.polygon.clear();
                for _ in 0..n {
                    let index = body.read(*item, place)?;
                    mesh.polygon.push(vertex_index(index, source)?);
                }
            }
            Property::List { count, item, .. } => skip_list(body, *count, *item, place)?,
            Property::Scalar { ty, .. } => {
                body.read(*ty, place)?;
            }
        }
    }
    if mesh.polygon.len() < 3 {
        return Err(ParseError::new(
            source.line,
            format!(
                "face {} has {} vertices; a face needs at least three",
                place.instance,
                mesh.polygon.len()
            ),
            "give the face three or more vertex indices, or remove it",
        ));
    }
    mesh.faces.add(&mesh.polygon, source);
    Ok(())
}

fn vertex_index(index: f64, source: FaceSource) -> Result<u32, ParseError> {
    if (0.0..=f64::from(u32::MAX)).contains(&index) {
        return Ok(index as u32);
    }
    Err(ParseError::new(
        source.line,
        format!("face {} refers to vertex {index}", source.face),
        "PLY vertex indices start at 0 and cannot be negative; fix or remove the face",
    ))
}

fn skip_instance(body: &mut Body, place: Place) -> Result<(), ParseError> {
    for property in &place.element.properties {
        match property {
            Property::Scalar { ty, .. } => {
                body.read(*ty, place)?;
            }
            Property::List { count, item, .. } => skip_list(body, *count, *item, place)?,
        }
    }
    Ok(())
}

fn skip_list(body: &mut Body, count: Scalar, item: Scalar, place: Place) -> Result<(), ParseError> {
    let n = body.read_count(count, place)?;
    for _ in 0..n {
        body.read(item, place)?;
    }
    Ok(())
}

/// The data after the header, read value by value.
enum Body<'a> {
    Ascii {
        text: &'a [u8],
        pos: usize,
        line: usize,
    },
    Binary {
        data: &'a [u8],
        pos: usize,
        big_endian: bool,
    },
}

impl Body<'_> {
    /// The line of the next value in an ASCII body.
    fn line(&mut self) -> Option<usize> {
        match self {
            Body::Ascii { text, pos, line } => {
                skip_whitespace(text, pos, line);
                Some(*line)
            }
            Body::Binary { .. } => None,
        }
    }

    fn read(&mut self, ty: Scalar, place: Place) -> Result<f64, ParseError> {
        match self {
            Body::Binary {
                data,
                pos,
                big_endian,
            } => {
                let bytes = data
                    .get(*pos..*pos + ty.size())
                    .ok_or_else(|| ended(place, None))?;
                *pos += ty.size();
                Ok(ty.decode(bytes, *big_endian))
            }
            Body::Ascii { text, pos, line } => {
                let token = next_token(text, pos, line).ok_or_else(|| ended(place, Some(*line)))?;
                parse_ascii_value(&token, ty).ok_or_else(|| {
                    let expected = if ty.is_integer() {
                        "an integer"
                    } else {
                        "a number"
                    };
                    ParseError::new(
                        Some(*line),
                        format!(
                            "'{}' in {} is not {expected}",
                            shorten(&token),
                            place.describe()
                        ),
                        TRUNCATED_HINT,
                    )
                })
            }
        }
    }

    /// A list length, which must be a non-negative whole number.
    fn read_count(&mut self, ty: Scalar, place: Place) -> Result<usize, ParseError> {
        let count = self.read(ty, place)?;
        if count >= 0.0 {
            return Ok(count as usize);
        }
        Err(ParseError::new(
            self.line(),
            format!(
                "a list in {} has the negative length {count}",
                place.describe()
            ),
            TRUNCATED_HINT,
        ))
    }
}

fn ended(place: Place, line: Option<usize>) -> ParseError {
    ParseError::new(
        line,
        format!("the file ends inside {}", place.describe()),
        TRUNCATED_HINT,
    )
}

fn skip_whitespace(text: &[u8], pos: &mut usize, line: &mut usize) {
    while let Some(&b) = text.get(*pos) {
        if !b.is_ascii_whitespace() {
            break;
        }
        if b == b'\n' {
            *line += 1;
        }
        *pos += 1;
    }
}

/// The next whitespace-separated token, counting the lines it passes.
fn next_token(text: &[u8], pos: &mut usize, line: &mut usize) -> Option<String> {
    skip_whitespace(text, pos, line);
    let start = *pos;
    while text.get(*pos).is_some_and(|b| !b.is_ascii_whitespace()) {
        *pos += 1;
    }
    (*pos > start).then(|| String::from_utf8_lossy(&text[start..*pos]).into_owned())
}

fn parse_ascii_value(token: &str, ty: Scalar) -> Option<f64> {
    if ty.is_integer() {
        token.parse::<i64>().ok().map(|v| v as f64)
    } else {
        token.parse::<f64>().ok()
    }
}
