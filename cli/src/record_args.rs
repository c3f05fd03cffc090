//! `--record-encoding`: how the recordings of `--record` are encoded.

use dynotraj_bag::record::RecordingEncoding;

/// The option every command with `--record` takes.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RecordEncodingArgs {
    /// The encoding of --record's recordings: protobuf (as Foxglove's SDKs write: Foxglove and
    /// rerun display it) or json (Foxglove's JSON encoding, every field of the schema present:
    /// Foxglove displays it, rerun does not).
    #[arg(long = "record-encoding", value_enum, default_value_t = EncodingArg::Protobuf, requires = "record", value_name = "ENCODING")]
    pub encoding: EncodingArg,
}

/// `--record-encoding` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EncodingArg {
    /// Protobuf, schemas as FileDescriptorSets.
    Protobuf,
    /// JSON, schemas as JSON Schemas.
    Json,
}

impl From<RecordEncodingArgs> for RecordingEncoding {
    fn from(a: RecordEncodingArgs) -> Self {
        match a.encoding {
            EncodingArg::Protobuf => Self::Protobuf,
            EncodingArg::Json => Self::Json,
        }
    }
}
