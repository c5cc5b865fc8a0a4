//! The output bag every offline command writes: created beside nothing it would
//! replace unless `--overwrite`, with zstd chunks unless `--uncompressed`.

use std::path::Path;

use anyhow::Context;
use stereocal_rosbag::{BagWriter, ChunkCompression, WriterOptions};

/// zstd level of output bags: 1, the MCAP C++ library's default level. On camera
/// images it compresses about three times as fast as zstd's own default (3), for files
/// about a tenth larger.
const ZSTD_LEVEL: u32 = 1;

/// Chunks of 8 MiB: at level 1 zstd's multithreaded mode cuts its input into jobs of
/// 2 MiB, so that a chunk is compressed by several workers at once.
const CHUNK_SIZE: u64 = 8 << 20;

/// Starts the output bag at `path`: replacing one already there only with `overwrite`,
/// its chunks zstd-compressed by one worker per core unless `uncompressed`.
pub fn create_output_bag(
    path: &Path,
    overwrite: bool,
    uncompressed: bool,
) -> anyhow::Result<BagWriter> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    BagWriter::create_with(
        path,
        WriterOptions {
            overwrite,
            compression: if uncompressed {
                ChunkCompression::None
            } else {
                ChunkCompression::Zstd
            },
            zstd_level: ZSTD_LEVEL,
            compression_threads: u32::try_from(cores).unwrap_or(u32::MAX),
            chunk_size: CHUNK_SIZE,
            ..WriterOptions::default()
        },
    )
    .with_context(|| format!("creating {}", path.display()))
}
