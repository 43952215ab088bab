//! The layout of report.json: indented like `serde_json`'s pretty printer, except that an array
//! whose elements are numbers (or booleans, or nulls) stays on one line.
//!
//! Why: report.json carries every raw spectrum and deviation (`psd[].freq_hz`, `value`, `dof`,
//! …). Pretty-printed one number a line, a single 10⁷-sample `psd` with 32 769 bins wrote 3.1 MB, a
//! third of it indentation, and formatting and writing it was the largest part of the command's
//! time after reading and the transforms. Objects keep one member a line, so the document reads as
//! before; only the long numeric columns are packed. The text parses to the same values.

use std::io::{self, Write};

use serde_json::ser::Formatter;

/// Pretty layout with numeric arrays on one line (see the module docs).
#[derive(Debug, Default)]
pub struct CompactArrays {
    /// The open arrays and objects, innermost last.
    open: Vec<Container>,
    /// An array element is about to start; its separator is written by the element itself, once
    /// its kind is known.
    pending: Option<Pending>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Container {
    Array(Layout),
    /// Whether it has had a member (an empty object is `{}`).
    Object {
        members: bool,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Layout {
    /// No element yet.
    Open,
    /// Scalars on the array's line.
    Inline,
    /// One element a line.
    Block,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    first: bool,
}

impl CompactArrays {
    fn indent<W: ?Sized + Write>(&self, w: &mut W) -> io::Result<()> {
        for _ in 0..self.open.len() {
            w.write_all(b"  ")?;
        }
        Ok(())
    }

    /// Writes the separator of a pending array element: `scalar` says whether the element is a
    /// number, boolean or null.
    fn separate<W: ?Sized + Write>(&mut self, w: &mut W, scalar: bool) -> io::Result<()> {
        let Some(Pending { first }) = self.pending.take() else {
            return Ok(());
        };
        let Some(Container::Array(layout)) = self.open.last_mut() else {
            unreachable!("serde_json starts array elements inside arrays only")
        };
        if *layout == Layout::Open {
            *layout = if scalar {
                Layout::Inline
            } else {
                Layout::Block
            };
        }
        match (*layout, first) {
            (Layout::Inline, true) => Ok(()),
            (Layout::Inline, false) => w.write_all(b", "),
            (_, first) => {
                w.write_all(if first { b"\n" } else { b",\n" })?;
                self.indent(w)
            }
        }
    }
}

/// The scalar writers: each places its element's separator first.
macro_rules! scalar_writers {
    ($($name:ident($t:ty)),* $(,)?) => {
        $(
            fn $name<W: ?Sized + Write>(&mut self, w: &mut W, value: $t) -> io::Result<()> {
                self.separate(w, true)?;
                serde_json::ser::CompactFormatter.$name(w, value)
            }
        )*
    };
}

impl Formatter for CompactArrays {
    scalar_writers!(
        write_bool(bool),
        write_i8(i8),
        write_i16(i16),
        write_i32(i32),
        write_i64(i64),
        write_i128(i128),
        write_u8(u8),
        write_u16(u16),
        write_u32(u32),
        write_u64(u64),
        write_u128(u128),
        write_f32(f32),
        write_f64(f64),
        write_number_str(&str),
    );

    fn write_null<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.separate(w, true)?;
        w.write_all(b"null")
    }

    fn begin_string<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.separate(w, false)?;
        w.write_all(b"\"")
    }

    fn begin_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.separate(w, false)?;
        self.open.push(Container::Array(Layout::Open));
        w.write_all(b"[")
    }

    fn begin_array_value<W: ?Sized + Write>(&mut self, _w: &mut W, first: bool) -> io::Result<()> {
        self.pending = Some(Pending { first });
        Ok(())
    }

    fn end_array_value<W: ?Sized + Write>(&mut self, _w: &mut W) -> io::Result<()> {
        Ok(())
    }

    fn end_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        if self.open.pop() == Some(Container::Array(Layout::Block)) {
            w.write_all(b"\n")?;
            self.indent(w)?;
        }
        w.write_all(b"]")
    }

    fn begin_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.separate(w, false)?;
        self.open.push(Container::Object { members: false });
        w.write_all(b"{")
    }

    fn begin_object_key<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        if let Some(Container::Object { members }) = self.open.last_mut() {
            *members = true;
        }
        w.write_all(if first { b"\n" } else { b",\n" })?;
        self.indent(w)
    }

    fn begin_object_value<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(b": ")
    }

    fn end_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        if self.open.pop() == Some(Container::Object { members: true }) {
            w.write_all(b"\n")?;
            self.indent(w)?;
        }
        w.write_all(b"}")
    }
}

/// Writes `value` as JSON in this layout.
pub fn write_json<W: Write, T: serde::Serialize + ?Sized>(
    out: W,
    value: &T,
) -> serde_json::Result<()> {
    let mut serializer = serde_json::Serializer::with_formatter(out, CompactArrays::default());
    value.serialize(&mut serializer)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    fn text(v: &Value) -> String {
        let mut out = Vec::new();
        write_json(&mut out, v).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn numbers_pack_and_everything_else_keeps_its_lines() {
        let doc = json!({
            "a": [1.5, -2, null, true],
            "b": [],
            "c": {},
            "d": [{"x": [0.25, 1e-300]}, {"y": "s"}, []],
            "e": ["one", "two"],
            "f": [[1, 2], [3]],
        });
        let expected = r#"{
  "a": [1.5, -2, null, true],
  "b": [],
  "c": {},
  "d": [
    {
      "x": [0.25, 1e-300]
    },
    {
      "y": "s"
    },
    []
  ],
  "e": [
    "one",
    "two"
  ],
  "f": [
    [1, 2],
    [3]
  ]
}"#;
        assert_eq!(text(&doc), expected);
        let back: Value = serde_json::from_str(&text(&doc)).unwrap();
        assert_eq!(back, doc);
    }

    #[test]
    fn without_numeric_arrays_it_is_serde_json_pretty() {
        let doc = json!({
            "name": "gyro_x", "nested": {"k": {"deep": "v"}, "empty": {}},
            "list": [{"a": "b"}, "c", {}], "none": [],
        });
        assert_eq!(text(&doc), serde_json::to_string_pretty(&doc).unwrap());
    }
}
