//! The output bag every offline command writes: created beside nothing it would
//! replace unless `--overwrite`, with zstd chunks unless `--uncompressed`.

use std::path::Path;

use anyhow::Context;
use stereocal_rosbag::{BagWriter, ChunkCompression, WriterOptions};

/// Starts the output bag at `path`: replacing one already there only with `overwrite`,
/// its chunks zstd-compressed unless `uncompressed`.
pub fn create_output_bag(
    path: &Path,
    overwrite: bool,
    uncompressed: bool,
) -> anyhow::Result<BagWriter> {
    BagWriter::create_with(
        path,
        WriterOptions {
            overwrite,
            compression: if uncompressed {
                ChunkCompression::None
            } else {
                ChunkCompression::Zstd
            },
            ..WriterOptions::default()
        },
    )
    .with_context(|| format!("creating {}", path.display()))
}
