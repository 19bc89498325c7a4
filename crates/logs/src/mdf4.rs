//! ASAM MDF4 measurement files, through `falcon_mdf` (the only place that crate is named).
//!
//! Every channel group with a master (time) channel is one time base; its numeric channels
//! become channels of the set, converted by their conversion rules (linear, rational, tables)
//! and carrying the unit the file gives. Groups holding CAN bus logging (`CAN_DataFrame`) are
//! decoded through the DBC when one is given. Compressed (DZ), listed (DL) and header-listed
//! (HL) data blocks are read by the crate. Only the channels a run column asks for are
//! decoded; the others are only listed, for errors.

use std::path::Path;

use airsus_data::{ChannelSet, DataError, DataErrorKind, Location, LogChannel, TimeBase};
use falcon_mdf::Mf4File;
use falcon_mdf::blocks::channel::DataType;

use crate::can::{self, CanDatabase};

const FORMAT: &str = "MDF4";

fn malformed(path: &Path, error: impl std::fmt::Display) -> DataError {
    DataError::in_file(
        path,
        DataErrorKind::Malformed {
            format: FORMAT,
            reason: error.to_string(),
        },
    )
}

/// Whether a channel's samples are numbers (not text, byte arrays or MIME payloads).
fn is_numeric(data_type: &DataType) -> bool {
    matches!(
        data_type,
        DataType::UIntLe
            | DataType::UIntBe
            | DataType::IntLe
            | DataType::IntBe
            | DataType::FloatLe
            | DataType::FloatBe
    )
}

/// Decodes the channels `wanted` names from every channel group, and the CAN frames of
/// bus-logging groups through `database`.
pub(crate) fn read_channels(
    path: &Path,
    wanted: &dyn Fn(&str) -> bool,
    database: Option<&CanDatabase>,
) -> Result<ChannelSet, DataError> {
    let file = Mf4File::open(path).map_err(|e| malformed(path, e))?;
    let mut set = ChannelSet {
        format: FORMAT,
        ..ChannelSet::default()
    };
    // Channels a column asks for but that cannot be read as numbers: they explain an error.
    let mut skipped_wanted: Vec<String> = Vec::new();
    let bus_groups: Vec<(usize, usize)> = file
        .can_frame_groups()
        .iter()
        .map(|g| (g.data_group_index, g.index))
        .collect();

    for data_group in file.data_groups() {
        for group in &data_group.channel_groups {
            if bus_groups.contains(&(group.data_group_index, group.index)) {
                continue;
            }
            let Some(master) = group.master_channel() else {
                for channel in &group.channels {
                    if wanted(&channel.name) {
                        skipped_wanted.push(format!(
                            "`{}` is in a channel group without a time channel",
                            channel.name
                        ));
                    }
                    set.unread.push(channel.name.clone());
                }
                continue;
            };
            let (chosen, skipped): (Vec<_>, Vec<_>) = group.channels.iter().partition(|c| {
                !c.is_master()
                    && c.unreadable().is_none()
                    && is_numeric(&c.data_type)
                    && wanted(&c.name)
            });
            for channel in skipped.iter().filter(|c| !c.is_master()) {
                if wanted(&channel.name) {
                    skipped_wanted.push(if channel.unreadable().is_some() {
                        format!("`{}` has a layout this reader cannot decode", channel.name)
                    } else {
                        format!("`{}` holds text or bytes, not numbers", channel.name)
                    });
                }
                set.unread.push(channel.name.clone());
            }
            if chosen.is_empty() {
                continue;
            }
            let time_s = file
                .signal(master)
                .and_then(|s| s.values_f64())
                .map_err(|e| {
                    DataError::new(
                        Location::file(path).channel(&master.name, None),
                        DataErrorKind::Malformed {
                            format: FORMAT,
                            reason: e.to_string(),
                        },
                    )
                })?;
            let base = set.bases.len();
            let group_name = if group.acquisition_name.is_empty() {
                format!("group {}.{}", group.data_group_index + 1, group.index + 1)
            } else {
                group.acquisition_name.clone()
            };
            set.bases.push(TimeBase {
                name: format!("{} of {group_name}", master.name),
                time_s,
                unit: non_empty(&master.unit),
            });
            let signals = file.signals(&chosen).map_err(|e| malformed(path, e))?;
            for (channel, signal) in chosen.iter().zip(signals) {
                let values = signal.values_f64().map_err(|e| {
                    DataError::new(
                        Location::file(path).channel(&channel.name, None),
                        DataErrorKind::Malformed {
                            format: FORMAT,
                            reason: e.to_string(),
                        },
                    )
                })?;
                set.channels.push(LogChannel {
                    name: channel.name.clone(),
                    unit: non_empty(&channel.unit),
                    base,
                    values,
                });
            }
        }
    }

    if !bus_groups.is_empty() {
        match database {
            Some(database) => {
                let mut all = Vec::with_capacity(bus_groups.len());
                for group in file.can_frame_groups() {
                    all.push(file.can_frames(group).map_err(|e| malformed(path, e))?);
                }
                // A logger channel within a channel group names a bus.
                let frames = all.iter().enumerate().flat_map(|(g, frames)| {
                    frames.iter().map(move |frame| can::FrameRef {
                        time_s: frame.timestamp,
                        bus: ((g as u32) << 8) | u32::from(frame.bus_channel),
                        id: frame.id,
                        data: frame.data,
                    })
                });
                let counts = can::decode_frames(&mut set, database, frames);
                set.notes.push(counts.describe());
            }
            None => {
                set.hint = Some(format!(
                    "the file logs CAN frames in {} channel group(s): give the DBC that decodes them (`dbc` in the study, `--dbc`)",
                    bus_groups.len()
                ));
            }
        }
    } else if database.is_some() {
        set.notes
            .push("a DBC was given, but the file logs no CAN frames".to_owned());
    }
    if !skipped_wanted.is_empty() {
        let reasons = skipped_wanted.join("; ");
        set.hint = Some(match set.hint.take() {
            Some(hint) => format!("{hint}; {reasons}"),
            None => reasons,
        });
    }
    Ok(set)
}

fn non_empty(unit: &str) -> Option<String> {
    let unit = unit.trim();
    (!unit.is_empty()).then(|| unit.to_owned())
}
