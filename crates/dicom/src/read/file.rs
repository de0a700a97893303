//! From bytes to a DICOM object: the "DICM" magic, the nesting pre-scan, parsing with dicom-object,
//! and the SOP class check that lets only RT Ion Plans through.

use std::io::Read;

use dicom_core::Tag;
use dicom_dictionary_std::{tags, uids, StandardSopClassDictionary};
use dicom_encoding::transfer_syntax::{Codec, TransferSyntaxIndex};
use dicom_object::file::ReadPreamble;
use dicom_object::{DefaultDicomObject, FileMetaTable, OpenFileOptions};
use dicom_parser::dataset::read::{DataSetReaderOptions, ValueReadStrategy};
use dicom_parser::dataset::{DataSetReader, DataToken};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;

use super::access::text;
use super::attr::SOP_CLASS_UID;
use super::Result;
use crate::error::{DicomImportError, Location};

/// SOP class UID of RT Ion Plan Storage, the only class this crate imports.
pub const RT_ION_PLAN_STORAGE: &str = uids::RT_ION_PLAN_STORAGE;
/// SOP class UID of (photon) RT Plan Storage, rejected with a dedicated message.
pub const RT_PLAN_STORAGE: &str = uids::RT_PLAN_STORAGE;

/// Length of the DICOM file preamble that precedes the "DICM" magic.
const PREAMBLE_LEN: usize = 128;

/// Deepest nesting of sequences accepted in a file (a sequence inside an item of a sequence is 2
/// levels). An RT Ion Plan needs fewer than 10 (IonBeamSequence > IonControlPointSequence >
/// ReferencedDoseReferenceSequence is 3). dicom-object builds nested sequences recursively, so a
/// file nested thousands of levels deep would overflow the stack and abort the process; such a file
/// is refused before it is parsed.
pub const MAX_NESTING: usize = 64;

/// True when `bytes` starts with a 128-byte preamble followed by "DICM".
pub fn has_dicom_magic(bytes: &[u8]) -> bool {
    bytes.get(PREAMBLE_LEN..PREAMBLE_LEN + 4) == Some(b"DICM".as_slice())
}

/// True when the file at `path` starts with a 128-byte preamble and "DICM" (whatever its extension).
pub fn is_dicom_file(path: impl AsRef<std::path::Path>) -> bool {
    let mut head = [0u8; PREAMBLE_LEN + 4];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .map(|()| has_dicom_magic(&head))
        .unwrap_or(false)
}

/// Parses a complete DICOM file held in memory (preamble, meta group, data set).
pub fn parse_bytes(bytes: &[u8]) -> Result<DefaultDicomObject> {
    if bytes.len() < PREAMBLE_LEN + 4 {
        return Err(DicomImportError::NotDicom {
            reason: format!(
                "{} bytes, shorter than the 128-byte preamble and \"DICM\" magic",
                bytes.len()
            ),
        });
    }
    if !has_dicom_magic(bytes) {
        return Err(DicomImportError::NotDicom {
            reason: "no \"DICM\" magic after the 128-byte preamble".into(),
        });
    }
    check_nesting(bytes)?;
    OpenFileOptions::new()
        .read_preamble(ReadPreamble::Always)
        .from_reader(bytes)
        .map_err(|e| DicomImportError::Unreadable {
            reason: error_chain(&e),
        })
}

/// Refuses a file whose data set is in a transfer syntax that cannot be read, and a file whose
/// sequences nest deeper than [`MAX_NESTING`], before dicom-object (which recurses once per level)
/// parses it. The scan walks the data set's tokens with dicom-parser's iterative reader (values
/// read as raw bytes, not decoded). Whatever the scan cannot read (meta group, a corrupt element)
/// ends it without error: the parser then reports it.
fn check_nesting(bytes: &[u8]) -> Result<()> {
    let Some(mut rest) = bytes.get(PREAMBLE_LEN..) else {
        return Ok(());
    };
    // Reads "DICM" and the meta group, leaving `rest` at the start of the data set.
    let Ok(meta) = FileMetaTable::from_reader(&mut rest) else {
        return Ok(());
    };
    let uid = meta.transfer_syntax().trim_end_matches(['\0', ' ']);
    let Some(ts) = TransferSyntaxRegistry.get(uid) else {
        return Err(DicomImportError::UnsupportedTransferSyntax {
            uid: uid.to_string(),
            name: None,
        });
    };
    let source: Box<dyn Read + '_> = match ts.codec() {
        Codec::Dataset(Some(adapter)) => adapter.adapt_reader(Box::new(rest)),
        Codec::Dataset(None) => {
            return Err(DicomImportError::UnsupportedTransferSyntax {
                uid: uid.to_string(),
                name: Some(ts.name()),
            })
        }
        Codec::None | Codec::EncapsulatedPixelData(..) => Box::new(rest),
    };
    let options = DataSetReaderOptions::default().value_read(ValueReadStrategy::Raw);
    let Ok(tokens) = DataSetReader::new_with_ts_options(source, ts, options) else {
        return Ok(());
    };
    let mut depth = 0usize;
    for token in tokens {
        match token {
            Ok(DataToken::SequenceStart { tag, .. }) => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(too_deep(tag));
                }
            }
            Ok(DataToken::PixelSequenceStart) => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(too_deep(tags::PIXEL_DATA));
                }
            }
            Ok(DataToken::SequenceEnd) => depth = depth.saturating_sub(1),
            Ok(_) => {}
            Err(_) => break,
        }
    }
    Ok(())
}

fn too_deep(tag: Tag) -> DicomImportError {
    use dicom_core::dictionary::DataDictionary;
    DicomImportError::TooDeeplyNested {
        limit: MAX_NESTING,
        keyword: dicom_dictionary_std::StandardDataDictionary
            .by_tag(tag)
            .map(|e| e.alias),
        tag,
    }
}

/// An error and its causes, joined by ": ".
fn error_chain(err: &dyn std::error::Error) -> String {
    let mut msg = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        source = cause.source();
    }
    msg
}

/// Checks the SOP class: RT Ion Plan passes, a photon RT Plan and everything else get a clear error.
pub fn check_sop_class(uid: Option<&str>) -> Result<()> {
    let Some(uid) = uid.map(|u| u.trim_end_matches(['\0', ' '])) else {
        return Err(DicomImportError::MissingTag {
            keyword: SOP_CLASS_UID.keyword,
            tag: SOP_CLASS_UID.tag,
            at: Location::Dataset,
            note: Some("cannot tell whether this is an RT Ion Plan"),
        });
    };
    match uid {
        RT_ION_PLAN_STORAGE => Ok(()),
        RT_PLAN_STORAGE => Err(DicomImportError::PhotonPlan {
            sop_class_uid: uid.to_string(),
        }),
        other => Err(DicomImportError::NotIonPlan {
            sop_class_uid: other.to_string(),
            name: sop_class_name(other),
        }),
    }
}

/// The standard name of SOP class `uid`, when it is a known one (for messages).
pub(crate) fn sop_class_name(uid: &str) -> Option<String> {
    use dicom_core::dictionary::UidDictionary;
    StandardSopClassDictionary
        .by_uid(uid)
        .map(|e| e.name.to_string())
}

/// The SOP class UID of a file: SOPClassUID (0008,0016) of the data set, else the meta group's
/// MediaStorageSOPClassUID (0002,0002).
pub fn sop_class_of(obj: &DefaultDicomObject) -> Option<String> {
    text(obj, SOP_CLASS_UID).or_else(|| {
        let uid = obj.meta().media_storage_sop_class_uid();
        (!uid.is_empty()).then(|| uid.to_string())
    })
}
