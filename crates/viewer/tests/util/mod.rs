//! Helpers shared by the viewer's test modules: where they write .rrd files, and an .rrd file
//! read back with Rerun's own decoder.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use arcsim_viewer::rerun::external::re_log_encoding::DecoderApp;
use arcsim_viewer::rerun::log::{Chunk, LogMsg};
use arcsim_viewer::rerun::{self, StoreKind};

/// A fresh path for an .rrd file, in its own temporary directory.
pub fn out_path(name: &str) -> PathBuf {
    arcsim_test_support::temp_dir().join(name)
}

/// What an .rrd file holds: recording chunks by entity path, and the blueprint part.
pub struct Rrd {
    pub entities: BTreeMap<String, Vec<Chunk>>,
    pub static_entities: Vec<String>,
    pub blueprint_chunks: usize,
    pub blueprint_activated: bool,
    /// Display names of the blueprint's views and containers (plot titles, tab names).
    pub blueprint_names: Vec<String>,
}

/// Every message of the .rrd file at `path`.
pub fn read_rrd(path: &Path) -> Rrd {
    let file = File::open(path).expect("open rrd");
    let mut rrd = Rrd {
        entities: BTreeMap::new(),
        static_entities: vec![],
        blueprint_chunks: 0,
        blueprint_activated: false,
        blueprint_names: vec![],
    };
    use rerun::external::re_sdk_types::blueprint::archetypes::{ContainerBlueprint, ViewBlueprint};
    let names = [
        ViewBlueprint::descriptor_display_name().component,
        ContainerBlueprint::descriptor_display_name().component,
    ];
    for msg in DecoderApp::decode_eager(BufReader::new(file)).expect("rrd header") {
        match msg.expect("rrd message") {
            LogMsg::ArrowMsg(store, arrow) => {
                let chunk = Chunk::from_arrow_msg(&arrow).expect("chunk");
                if store.kind() == StoreKind::Blueprint {
                    rrd.blueprint_chunks += 1;
                    for name in names {
                        for batch in chunk.iter_slices::<String>(name) {
                            rrd.blueprint_names
                                .extend(batch.into_iter().map(|s| s.to_string()));
                        }
                    }
                } else {
                    let path = chunk.entity_path().to_string();
                    if chunk.is_static() {
                        rrd.static_entities.push(path.clone());
                    }
                    rrd.entities.entry(path).or_default().push(chunk);
                }
            }
            LogMsg::BlueprintActivationCommand(cmd) => rrd.blueprint_activated |= cmd.make_active,
            LogMsg::SetStoreInfo(_) => {}
        }
    }
    rrd
}

impl Rrd {
    /// The chunks logged to entity `path` (without its leading `/`); panics naming the entities
    /// there are when it has none.
    pub fn chunks(&self, path: &str) -> &[Chunk] {
        let key = format!("/{path}");
        self.entities
            .get(&key)
            .map(Vec::as_slice)
            .unwrap_or_else(|| panic!("no entity {key}; have {:?}", self.entities.keys()))
    }
}
