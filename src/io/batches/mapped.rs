//! Arrow IPC files read through a memory map: each record batch's buffers are views of the
//! file's pages in the page cache, not copies.
//!
//! **Why.** `arrow_ipc`'s `FileReader` reads every batch body into a freshly allocated, zeroed
//! buffer: on a file of one batch of 10⁷ f64 rows that is 76 MiB zeroed, faulted in page by page
//! and then overwritten by the read, 23 % of `avar`'s CPU (the page faults of the read stage were
//! half of the whole run). Mapped, the batch is the file's pages: no zeroing, no copy, and the
//! kernel maps them sixteen at a time (fault-around) instead of allocating and clearing each.
//! The samples are converted to f64 blocks right after ([`crate::io::BlockReader`]), so the map
//! is read once, front to back.
//!
//! **Bounds.** Every block the footer names is checked against the file's length before it is
//! sliced, so a footer that points past the end is an error naming the batch, not a panic. The
//! footer and schema themselves were validated when the schema was read
//! ([`super::read_schema`]); they are parsed again here because the map is the file as it is now.
//!
//! **The one risk of a map.** A file truncated by another process *while* it is being read makes
//! the next access to a vanished page a SIGBUS, which no error handling can turn into an error
//! row. A logger that appends to a file it is writing does not truncate it; a file replaced by a
//! rename keeps its old pages for as long as the map lives. Files rewritten in place during a
//! screen are not supported (the Arrow IPC file format only becomes readable once its footer is
//! written, so a logger cannot be caught half-way through a file it is still writing).

use std::fs::File;
use std::ptr::NonNull;
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_buffer::Buffer;
use arrow_ipc::reader::{read_footer_length, FileDecoder};
use arrow_ipc::{Block, MetadataVersion};

/// The 10-byte trailer of an Arrow IPC file: footer length (4) and the magic `ARROW1` (6).
const TRAILER: usize = 10;

/// The record batches of the Arrow IPC `file`, with only the columns `projection` (indices into
/// its schema, in the order given), as views of a map of the file.
pub(super) fn batches(
    file: &File,
    projection: Vec<usize>,
) -> Result<Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>, String> {
    // SAFETY: the map is only read, through `Buffer`s that keep it alive; see the module's docs
    // for what happens if another process truncates the file while it is mapped.
    let map =
        Arc::new(unsafe { memmap2::Mmap::map(file) }.map_err(|e| format!("cannot map: {e}"))?);
    let len = map.len();
    // A hint only (read-ahead): no error of it matters.
    #[cfg(unix)]
    let _ = map.advise(memmap2::Advice::Sequential);
    if len < TRAILER {
        return Err(format!("the file is only {len} bytes long"));
    }
    let ptr = NonNull::new(map.as_ptr().cast_mut())
        .ok_or_else(|| "the map of the file is empty".to_string())?;
    // SAFETY: `ptr` and `len` describe the mapped bytes, which live as long as the `Mmap` the
    // buffer owns.
    let buffer = unsafe { Buffer::from_custom_allocation(ptr, len, map.clone()) };
    let trailer: [u8; TRAILER] = buffer[len - TRAILER..]
        .try_into()
        .map_err(|_| "the trailer is cut".to_string())?;
    let footer_len = read_footer_length(trailer).map_err(|e| e.to_string())?;
    let footer_start = (len - TRAILER)
        .checked_sub(footer_len)
        .ok_or_else(|| format!("its footer ({footer_len} bytes) is longer than the file"))?;
    let footer = arrow_ipc::root_as_footer(&buffer[footer_start..len - TRAILER])
        .map_err(|e| format!("unable to read its footer: {e}"))?;
    let schema = footer
        .schema()
        .ok_or_else(|| "its footer holds no schema".to_string())
        .and_then(|s| arrow_ipc::convert::try_fb_to_schema(s).map_err(|e| e.to_string()))?;
    let version: MetadataVersion = footer.version();
    let mut decoder = FileDecoder::new(Arc::new(schema), version).with_projection(projection);
    for (i, block) in footer.dictionaries().iter().flatten().enumerate() {
        let data = slice(&buffer, block, "dictionary", i)?;
        decoder
            .read_dictionary(block, &data)
            .map_err(|e| e.to_string())?;
    }
    let blocks: Vec<Block> = footer
        .recordBatches()
        .map(|b| b.iter().copied().collect())
        .unwrap_or_default();
    Ok(Box::new(Mapped {
        map,
        buffer,
        decoder,
        blocks: blocks.into_iter(),
        index: 0,
        read: None,
    }))
}

/// The record batches of a mapped file, in order.
struct Mapped {
    map: Arc<memmap2::Mmap>,
    buffer: Buffer,
    decoder: FileDecoder,
    blocks: std::vec::IntoIter<Block>,
    index: usize,
    /// The bytes of the batch handed on last (start, length).
    read: Option<(usize, usize)>,
}

impl Iterator for Mapped {
    type Item = Result<RecordBatch, String>;

    fn next(&mut self) -> Option<Self::Item> {
        // The caller has converted the batch before asking for the next one: its pages leave
        // this process's resident set (they stay in the page cache; a later access would map
        // them again), so that reading a file of gigabytes does not hold all of it resident.
        #[cfg(unix)]
        if let Some((start, len)) = self.read.take() {
            // SAFETY: the map is of a file opened read-only and shared: after MADV_DONTNEED
            // an access maps the same file pages again, so no view of it can see other data.
            let _ = unsafe {
                self.map
                    .unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, start, len)
            };
        }
        let block = self.blocks.next()?;
        let i = self.index;
        self.index += 1;
        let batch = slice(&self.buffer, &block, "record batch", i).and_then(|data| {
            self.read = Some((block.offset() as usize, data.len()));
            self.decoder
                .read_record_batch(&block, &data)
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("record batch {i} is not a record batch"))
        });
        Some(batch)
    }
}

/// The bytes of `block` (its message and body) in `file`, or why they are not there.
fn slice(file: &Buffer, block: &Block, what: &str, i: usize) -> Result<Buffer, String> {
    let len = file.len();
    let start = usize::try_from(block.offset()).ok();
    let size = usize::try_from(block.metaDataLength())
        .ok()
        .zip(usize::try_from(block.bodyLength()).ok())
        .and_then(|(m, b)| m.checked_add(b));
    match (start, size) {
        (Some(start), Some(size)) if start.checked_add(size).is_some_and(|e| e <= len) => {
            Ok(file.slice_with_length(start, size))
        }
        _ => Err(format!(
            "{what} {i} lies beyond the end of the file (offset {}, {} + {} bytes; the file has {len})",
            block.offset(),
            block.metaDataLength(),
            block.bodyLength()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Float32Array, Float64Array, Int64Array};
    use arrow_schema::{DataType, Field, Schema};

    /// An Arrow IPC file of three columns (i64, f64, f32) written in batches of `rows` rows.
    fn write(path: &std::path::Path, total: usize, rows: usize) {
        let schema = Arc::new(Schema::new(vec![
            Field::new("t", DataType::Int64, false),
            Field::new("a", DataType::Float64, false),
            Field::new("b", DataType::Float32, false),
        ]));
        let file = File::create(path).unwrap();
        let mut w = arrow_ipc::writer::FileWriter::try_new(file, &schema).unwrap();
        for start in (0..total).step_by(rows) {
            let n = rows.min(total - start);
            let t = Int64Array::from_iter_values((start..start + n).map(|i| i as i64));
            let a = Float64Array::from_iter_values((start..start + n).map(|i| (i as f64).sin()));
            let b = Float32Array::from_iter_values((start..start + n).map(|i| i as f32 * 0.5));
            let batch =
                RecordBatch::try_new(schema.clone(), vec![Arc::new(t), Arc::new(a), Arc::new(b)])
                    .unwrap();
            w.write(&batch).unwrap();
        }
        w.finish().unwrap();
    }

    #[test]
    fn mapped_batches_are_the_readers_batches_projected_in_the_order_asked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.arrow");
        write(&path, 10_000, 3_000);
        let projection = vec![2, 0];
        let ours: Vec<RecordBatch> = batches(&File::open(&path).unwrap(), projection.clone())
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        let theirs: Vec<RecordBatch> =
            arrow_ipc::reader::FileReader::try_new(File::open(&path).unwrap(), Some(projection))
                .unwrap()
                .collect::<Result<_, _>>()
                .unwrap();
        assert_eq!(ours.len(), 4);
        assert_eq!(ours, theirs);
        assert_eq!(ours[0].schema().field(0).name(), "b");
        assert_eq!(ours[3].num_rows(), 1_000);
    }

    #[test]
    fn a_file_whose_footer_points_past_its_end_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.arrow");
        write(&path, 10_000, 3_000);
        let bytes = std::fs::read(&path).unwrap();
        // The footer kept, a third of the batches' bytes cut from the middle: the footer's blocks
        // now point at other bytes or past the end.
        let (third, len) = (bytes.len() / 3, bytes.len());
        let mut cut = bytes[..third].to_vec();
        cut.extend_from_slice(&bytes[2 * third..len]);
        let bad = dir.path().join("cut.arrow");
        std::fs::write(&bad, &cut).unwrap();
        let read = std::panic::catch_unwind(|| {
            batches(&File::open(&bad).unwrap(), vec![0, 1, 2])
                .and_then(|it| it.collect::<Result<Vec<_>, _>>())
        })
        .expect("no panic");
        let e = read.expect_err("a cut file is an error");
        assert!(!e.is_empty());
        // Shorter than the trailer.
        std::fs::write(&bad, b"ARROW1").unwrap();
        let e = batches(&File::open(&bad).unwrap(), vec![0]).err().unwrap();
        assert_eq!(e, "the file is only 6 bytes long");
    }
}
