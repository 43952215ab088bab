//! A minimal SVG element writer.
//!
//! Every number goes through [`num`], which rounds to 0.01 px: finer is invisible even at 4×
//! rasterisation, and it keeps files small and output byte-identical across platforms (no
//! 17-digit float tails). Every string goes through [`escape`], so titles such as `a < b & c`
//! cannot break the document.

use std::fmt::Write;

/// A coordinate or length with at most two decimals, trailing zeros trimmed, never `-0`.
/// Non-finite values become 0 (callers filter data before this; this only guards layout
/// arithmetic on degenerate figures from ever writing `NaN` into the document).
pub(super) fn num(v: f64) -> String {
    if !v.is_finite() {
        return "0".to_string();
    }
    trim(format!("{:.2}", v))
}

/// Trims trailing zeros of a decimal number and turns `-0` into `0`.
pub(super) fn trim(mut s: String) -> String {
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".to_string();
    }
    s
}

/// XML-escapes text and attribute values (both quote kinds, so either quoting is safe).
pub(super) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0; drop them rather than fail.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => {}
            c => out.push(c),
        }
    }
    out
}

/// Approximate advance width of `s` in DejaVu Sans at `size` px. We lay out without access to
/// the font (the SVG must be writable without rasterising it), so this per-class table of the
/// font's real advances is used to size the left margin, the legend box and tick-label
/// spacing. It errs slightly wide, which only costs a little whitespace.
pub(super) fn text_width(s: &str, size: f64) -> f64 {
    let em: f64 = s
        .chars()
        .map(|c| match c {
            'i' | 'j' | 'l' | '.' | ',' | ':' | ';' | '|' | '!' | '\'' | ' ' => 0.3,
            'f' | 't' | 'r' | '(' | ')' | '[' | ']' | '{' | '}' | '-' | '/' | 'I' => 0.42,
            'm' | 'w' | 'M' | 'W' | '%' | '@' => 0.95,
            '0'..='9' | 'a'..='z' => 0.64,
            'A'..='Z' => 0.74,
            '−' | '×' | '+' | '=' | '<' | '>' | '±' | '~' => 0.84,
            _ => 0.7,
        })
        .sum();
    em * size
}

/// An element under construction: `Tag::new("line").n("x1", 3.0).s("stroke", "#000")`.
pub(super) struct Tag {
    name: &'static str,
    buf: String,
}

impl Tag {
    pub(super) fn new(name: &'static str) -> Tag {
        Tag {
            name,
            buf: format!("<{name}"),
        }
    }

    /// Numeric attribute.
    pub(super) fn n(mut self, key: &str, v: f64) -> Tag {
        let _ = write!(self.buf, " {key}=\"{}\"", num(v));
        self
    }

    /// Several numeric attributes.
    pub(super) fn ns(self, kv: &[(&str, f64)]) -> Tag {
        kv.iter().fold(self, |t, (k, v)| t.n(k, *v))
    }

    /// Several string attributes.
    pub(super) fn ss(self, kv: &[(&str, &str)]) -> Tag {
        kv.iter().fold(self, |t, (k, v)| t.s(k, v))
    }

    pub(super) fn line(x1: f64, y1: f64, x2: f64, y2: f64) -> Tag {
        Tag::new("line").ns(&[("x1", x1), ("y1", y1), ("x2", x2), ("y2", y2)])
    }

    pub(super) fn rect(x: f64, y: f64, width: f64, height: f64) -> Tag {
        Tag::new("rect").ns(&[("x", x), ("y", y), ("width", width), ("height", height)])
    }

    /// String attribute (escaped).
    pub(super) fn s(mut self, key: &str, v: &str) -> Tag {
        let _ = write!(self.buf, " {key}=\"{}\"", escape(v));
        self
    }

    /// Self-closing element.
    pub(super) fn end(self, out: &mut String) {
        out.push_str(&self.buf);
        out.push_str("/>\n");
    }

    /// Opening tag only; the caller writes children and `</name>`.
    pub(super) fn open(self, out: &mut String) {
        out.push_str(&self.buf);
        out.push_str(">\n");
    }

    /// Element with already-escaped inner markup.
    pub(super) fn wrap(self, out: &mut String, inner: &str) {
        let _ = writeln!(out, "{}>{}</{}>", self.buf, inner, self.name);
    }
}

/// Path data under construction: `cmd('M', &[x, y])` appends `Mx,y` with rounded numbers.
#[derive(Default)]
pub(super) struct PathData(pub String);

impl PathData {
    pub(super) fn cmd(&mut self, c: char, args: &[f64]) {
        self.0.push(c);
        for (i, v) in args.iter().enumerate() {
            if i > 0 {
                self.0.push(',');
            }
            self.0.push_str(&num(*v));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_two_decimals_at_most() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(1.23456), "1.23");
        assert_eq!(num(-0.001), "0");
        assert_eq!(num(10.5), "10.5");
        assert_eq!(num(f64::NAN), "0");
        assert_eq!(num(120.0), "120");
    }

    #[test]
    fn escape_covers_markup_and_quotes() {
        assert_eq!(
            escape("a < b & c > \"d\" 'e'"),
            "a &lt; b &amp; c &gt; &quot;d&quot; &apos;e&apos;"
        );
        assert_eq!(escape("τ σ √ ² µ °"), "τ σ √ ² µ °");
        assert_eq!(escape("a\u{1}b"), "ab");
    }

    #[test]
    fn tag_writes_attributes() {
        let mut out = String::new();
        Tag::new("line")
            .n("x1", 1.005)
            .s("stroke", "#000")
            .end(&mut out);
        assert_eq!(out, "<line x1=\"1\" stroke=\"#000\"/>\n");
        let mut out = String::new();
        Tag::new("text").n("x", 2.0).wrap(&mut out, "a&amp;b");
        assert_eq!(out, "<text x=\"2\">a&amp;b</text>\n");
        let mut d = PathData::default();
        d.cmd('M', &[1.0, 2.556]);
        d.cmd('V', &[-0.001]);
        assert_eq!(d.0, "M1,2.56V0");
    }
}
