//! 3MF (3D Manufacturing Format, core specification 1.x): a zip package of
//! `[Content_Types].xml`, `_rels/.rels` and the model part
//! `3D/3dmodel.model`, whose XML holds one `<object>` with a `<mesh>` per
//! mesh (vertices in the model's unit, millimetres by default; triangles
//! counter-clockwise seen from outside, as the mesh's are) and one build
//! item per object.
//!
//! The zip container is the `zip` crate's; the three small XML parts are
//! written here. The `threemf` crate was considered and not used: it names
//! the model part `3D/model.model` (the core specification's conventional
//! name is `3D/3dmodel.model`), always declares the materials namespace,
//! and serialises the whole model through serde into one `String` of
//! per-vertex structs, several times the mesh's size; writing the XML
//! directly streams it into the compressor.

use std::io::{Cursor, Write};

use crate::mesh::Mesh;

/// Units a 3MF model can be in (`--unit`); the default is millimetres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Unit {
    /// Micrometres.
    Micron,
    /// Millimetres (the 3MF default).
    #[default]
    Millimeter,
    /// Centimetres.
    Centimeter,
    /// Inches.
    Inch,
    /// Feet.
    Foot,
    /// Metres.
    Meter,
}

impl Unit {
    /// Every unit, in the order of the specification.
    pub const ALL: [Unit; 6] = [
        Unit::Micron,
        Unit::Millimeter,
        Unit::Centimeter,
        Unit::Inch,
        Unit::Foot,
        Unit::Meter,
    ];

    /// The name 3MF uses (the `unit` attribute).
    pub fn name(self) -> &'static str {
        match self {
            Unit::Micron => "micron",
            Unit::Millimeter => "millimeter",
            Unit::Centimeter => "centimeter",
            Unit::Inch => "inch",
            Unit::Foot => "foot",
            Unit::Meter => "meter",
        }
    }
}

impl std::str::FromStr for Unit {
    type Err = String;

    /// A unit by its 3MF name (`millimeter`, …; `mm`, `cm`, `m`, `in`,
    /// `ft`, `um` and the British spellings are accepted too).
    fn from_str(s: &str) -> Result<Unit, String> {
        let u = match s.trim().to_ascii_lowercase().as_str() {
            "micron" | "um" | "micrometer" | "micrometre" => Unit::Micron,
            "millimeter" | "millimetre" | "mm" => Unit::Millimeter,
            "centimeter" | "centimetre" | "cm" => Unit::Centimeter,
            "inch" | "in" => Unit::Inch,
            "foot" | "ft" => Unit::Foot,
            "meter" | "metre" | "m" => Unit::Meter,
            _ => {
                let names: Vec<&str> = Unit::ALL.iter().map(|u| u.name()).collect();
                return Err(format!(
                    "unknown unit `{s}`; use one of {}",
                    names.join(", ")
                ));
            }
        };
        Ok(u)
    }
}

const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
</Types>
"#;

const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"#;

/// The model part's path in the package.
pub const MODEL_PART: &str = "3D/3dmodel.model";

/// Writes `mesh` as a 3MF package in millimetres.
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    write_objects(&[mesh], Unit::Millimeter, out)
}

/// Writes a 3MF package with one object per mesh that has triangles, in
/// `unit`. The core specification requires a mesh object to have
/// triangles, so an empty mesh becomes no object: a package of only empty
/// meshes has empty `<resources>` and `<build>` (a valid, empty model).
pub fn write_objects(meshes: &[&Mesh], unit: Unit, out: &mut dyn Write) -> std::io::Result<()> {
    // The zip writer seeks back to patch each entry's header, so the
    // package is assembled in memory (compressed) and copied to `out`.
    // Vertices take about 70 bytes of XML, triangles 50: past 4 GiB the
    // model part needs zip64 sizes.
    let xml: usize = meshes
        .iter()
        .map(|m| 70 * m.positions.len() + 50 * m.triangles.len())
        .sum();
    let large = xml as u64 > u64::from(u32::MAX) / 2;
    let bytes = package(Cursor::new(Vec::new()), large, |w| {
        model_xml(meshes, unit, w)
    })?
    .into_inner();
    out.write_all(&bytes)
}

/// Writes the package into `sink`, the model part's XML by `model`
/// (`large`: it may pass 4 GiB, and needs zip64 sizes).
pub(crate) fn package<W: Write + std::io::Seek>(
    sink: W,
    large: bool,
    model: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<W> {
    let mut zip = zip::ZipWriter::new(sink);
    let deflated = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    let zerr = |e: zip::result::ZipError| std::io::Error::other(e.to_string());
    zip.start_file("[Content_Types].xml", deflated)
        .map_err(zerr)?;
    zip.write_all(CONTENT_TYPES.as_bytes())?;
    zip.start_file("_rels/.rels", deflated).map_err(zerr)?;
    zip.write_all(RELS.as_bytes())?;
    zip.start_file(MODEL_PART, deflated.large_file(large))
        .map_err(zerr)?;
    {
        let mut w = std::io::BufWriter::with_capacity(1 << 16, &mut zip);
        model(&mut w)?;
        w.flush()?;
    }
    zip.finish().map_err(zerr)
}

/// The model part's XML.
fn model_xml(meshes: &[&Mesh], unit: Unit, w: &mut dyn Write) -> std::io::Result<()> {
    model_start(unit, w)?;
    let meshes: Vec<&Mesh> = meshes
        .iter()
        .copied()
        .filter(|m| !m.triangles.is_empty())
        .collect();
    for (k, mesh) in meshes.iter().enumerate() {
        object_start(k + 1, w)?;
        for p in &mesh.positions {
            vertex(*p, w)?;
        }
        vertices_end(w)?;
        for t in &mesh.triangles {
            triangle(*t, w)?;
        }
        object_end(w)?;
    }
    model_end(meshes.len(), w)
}

/// The model's opening, up to its resources.
pub(crate) fn model_start(unit: Unit, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        w,
        r#"<model unit="{}" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">"#,
        unit.name()
    )?;
    writeln!(w, r#" <metadata name="Application">isoc</metadata>"#)?;
    writeln!(w, " <resources>")
}

/// An object's opening, up to its first vertex.
pub(crate) fn object_start(id: usize, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, r#"  <object id="{id}" type="model">"#)?;
    writeln!(w, "   <mesh>\n    <vertices>")
}

/// One vertex (`{}` on f64 is the shortest form that reads back exactly).
pub(crate) fn vertex(p: glam::DVec3, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, r#"     <vertex x="{}" y="{}" z="{}"/>"#, p.x, p.y, p.z)
}

/// Between an object's vertices and its triangles.
pub(crate) fn vertices_end(w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "    </vertices>\n    <triangles>")
}

/// One triangle.
pub(crate) fn triangle(t: [u32; 3], w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        w,
        r#"     <triangle v1="{}" v2="{}" v3="{}"/>"#,
        t[0], t[1], t[2]
    )
}

/// An object's closing.
pub(crate) fn object_end(w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "    </triangles>\n   </mesh>\n  </object>")
}

/// The model's closing: the build, one item per object `1..=objects`.
pub(crate) fn model_end(objects: usize, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, " </resources>\n <build>")?;
    for k in 0..objects {
        writeln!(w, r#"  <item objectid="{}"/>"#, k + 1)?;
    }
    writeln!(w, " </build>\n</model>")
}
