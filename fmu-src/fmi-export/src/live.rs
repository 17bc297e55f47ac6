//! Which `fmi2Component` and `fmi2FMUstate` values are live instances and FMU states of this
//! library.
//!
//! The standard leaves a call with a freed or foreign component undefined (FMI 2.0.4, 2.1.5:
//! the component is only valid between `fmi2Instantiate` and `fmi2FreeInstance`), and a master
//! that makes one anyway must not bring down the process. One does: FMI++ 2.1
//! (`fmi_2_0::FMUCoSimulation`, import/base/src/FMUCoSimulation_v2.cpp) frees the instance in
//! its `terminate()` without forgetting it, and its destructor calls `fmi2Terminate` and
//! `fmi2FreeInstance` on it again; reading the freed instance aborted the process with an
//! allocation of 6.9e18 bytes (a length read from string bytes), `catch_unwind` cannot help.
//!
//! So the component a master holds is not the instance's address but a handle: a one-byte heap
//! allocation whose address is unique while it is allocated, listed here with its instance.
//! Every call looks its component up first; one that is not listed (freed, never ours, of
//! another model in the same process) answers `fmi2Error`, and `fmi2FreeInstance` ignores it.
//! Nothing can be logged for it: the logger belongs to the instance. FMU states are handles of
//! the same list, told apart by their type: a freed or foreign state answers `fmi2Error` with a
//! log line of the instance it was passed to.
//!
//! A freed handle is kept in a quarantine of the last [`QUARANTINE`] freed handles before its
//! memory is released, so that an instance created right after a free (FMI++'s pattern: the
//! next object is constructed before the old one's destructor runs) gets another address and
//! the stale calls cannot reach it. Beyond that many frees the address may be reused; a stale
//! call on a reused address reaches the new instance, which the standard's rule, not this list,
//! must prevent.

use std::any::TypeId;
use std::collections::VecDeque;
use std::sync::{Mutex, MutexGuard};

use crate::ffi::Fmi2Component;

/// How many freed handles stay allocated before their memory is released (one-byte allocations,
/// a few KiB per loaded library at most).
pub const QUARANTINE: usize = 64;

struct Entry {
    /// Owns the handle's allocation; its address is the component.
    handle: Box<u8>,
    /// `Box::into_raw` of the instance.
    instance: usize,
    /// The model type of the instance (a process may hold several in tests).
    model: TypeId,
}

struct Registry {
    live: Vec<Entry>,
    quarantine: VecDeque<Box<u8>>,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    live: Vec::new(),
    quarantine: VecDeque::new(),
});

/// The registry; a poisoned lock is taken as it is (nothing panics while holding it, and the
/// list stays consistent between statements).
fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn address(handle: &u8) -> usize {
    handle as *const u8 as usize
}

/// Lists `instance` (from `Box::into_raw`) of model `model` and returns its component.
pub(crate) fn register(instance: usize, model: TypeId) -> Fmi2Component {
    let handle = Box::new(0u8);
    let component = address(&handle) as Fmi2Component;
    registry().live.push(Entry {
        handle,
        instance,
        model,
    });
    component
}

/// The instance of `component` if it is a live instance of `model`.
pub(crate) fn lookup(component: Fmi2Component, model: TypeId) -> Option<usize> {
    let key = component as usize;
    registry()
        .live
        .iter()
        .find(|entry| address(&entry.handle) == key && entry.model == model)
        .map(|entry| entry.instance)
}

/// Unlists `component` and returns its instance, for the caller to drop; `None` when it is not
/// a live instance of `model` (freed already, or never ours). The handle goes to the quarantine.
pub(crate) fn unregister(component: Fmi2Component, model: TypeId) -> Option<usize> {
    let key = component as usize;
    let mut registry = registry();
    let position = registry
        .live
        .iter()
        .position(|entry| address(&entry.handle) == key && entry.model == model)?;
    let entry = registry.live.swap_remove(position);
    if registry.quarantine.len() == QUARANTINE {
        registry.quarantine.pop_front();
    }
    registry.quarantine.push_back(entry.handle);
    Some(entry.instance)
}
