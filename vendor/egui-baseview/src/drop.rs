//! Struck patch: baseview's file drag and drop, translated for egui.
//!
//! egui-baseview 0.9.0 ignores baseview's `DragEntered` / `DragMoved` / `DragLeft` /
//! `DragDropped` mouse events, so files dropped on a plugin window never reach egui. These
//! helpers turn them into egui's `RawInput::hovered_files` / `dropped_files` and tell the
//! platform that file drags are accepted (as a copy).

use baseview::{DropData, DropEffect, Event, EventStatus, MouseEvent};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The paths a drag carries (none for other data).
pub(crate) fn dropped_paths(data: &DropData) -> &[PathBuf] {
    match data {
        DropData::Files(files) => files,
        _ => &[],
    }
}

/// A dropped file known by its path; read on demand.
#[derive(Debug)]
struct DroppedPath(PathBuf);

impl egui::DroppedFile for DroppedPath {
    fn path(&self) -> &Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| format!("{}: {e}", self.0.display()))
    }
}

/// egui handles for the dropped files.
pub(crate) fn file_handles(data: &DropData) -> Vec<egui::DroppedFileHandle> {
    dropped_paths(data)
        .iter()
        .map(|p| Arc::new(DroppedPath(p.clone())) as egui::DroppedFileHandle)
        .collect()
}

/// What to answer the platform for a drag event: accept (copy) drags that carry files,
/// ignore others; `None` for events that are not drags.
pub(crate) fn drop_status(event: &Event) -> Option<EventStatus> {
    match event {
        Event::Mouse(
            MouseEvent::DragEntered { data, .. }
            | MouseEvent::DragMoved { data, .. }
            | MouseEvent::DragDropped { data, .. },
        ) => Some(if dropped_paths(data).is_empty() {
            EventStatus::Ignored
        } else {
            EventStatus::AcceptDrop(DropEffect::Copy)
        }),
        Event::Mouse(MouseEvent::DragLeft) => Some(EventStatus::Captured),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use baseview::dpi::PhysicalPosition;

    fn drag(data: DropData) -> Event {
        Event::Mouse(MouseEvent::DragDropped {
            position: PhysicalPosition { x: 10.0, y: 20.0 },
            modifiers: keyboard_types::Modifiers::empty(),
            data,
        })
    }

    #[test]
    fn file_drags_are_accepted_and_become_egui_files() {
        let files = vec![PathBuf::from("/tmp/a.wav"), PathBuf::from("/tmp/b.wav")];
        let data = DropData::Files(files.clone());
        assert_eq!(drop_status(&drag(data.clone())), Some(EventStatus::AcceptDrop(DropEffect::Copy)));
        let handles = file_handles(&data);
        let paths: Vec<&Path> = handles.iter().map(|h| h.path()).collect();
        assert_eq!(paths, [files[0].as_path(), files[1].as_path()]);
        assert!(handles[0].bytes().unwrap_err().contains("/tmp/a.wav"));
    }

    #[test]
    fn other_drags_and_events_are_not_accepted() {
        assert_eq!(drop_status(&drag(DropData::None)), Some(EventStatus::Ignored));
        assert!(file_handles(&DropData::None).is_empty());
        assert_eq!(drop_status(&Event::Mouse(MouseEvent::DragLeft)), Some(EventStatus::Captured));
        assert_eq!(drop_status(&Event::Mouse(MouseEvent::CursorLeft)), None);
    }
}
