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
//! So the component a master holds is not the instance's address but a handle, listed here with
//! its instance. Every call looks its component up first; one that is not listed (freed, never
//! ours, of another model in the same process) answers `fmi2Error`, and `fmi2FreeInstance`
//! ignores it. Nothing can be logged for it: the logger belongs to the instance. FMU states are
//! handles of the same list, told apart by their type: a freed or foreign state answers
//! `fmi2Error` with a log line of the instance it was passed to.
//!
//! A handle is an address inside [`HANDLE_SPACE`], a static region of this library that nothing
//! else is ever allocated at (zero-initialised and never touched, so it occupies address space,
//! not memory), taken in turn: a freed handle comes back only after [`HANDLE_COUNT`] handles
//! more, so a stale call cannot reach a later instance or state in any run a master makes (the
//! first form, one-byte heap allocations kept for 64 frees, gave a freed address back to the
//! allocator after that many). A foreign pointer cannot be a handle: no allocation of anyone
//! lies in the region.

use std::any::TypeId;
use std::sync::atomic::AtomicU8;
use std::sync::{Mutex, MutexGuard};

use crate::ffi::Fmi2Component;

/// How many handles are handed out before the first comes back (16 Mi: 16 MiB of address space
/// per loaded library).
pub const HANDLE_COUNT: usize = 1 << 24;

/// The addresses handles are taken from. Atomics make it a writable, zero-initialised static
/// (`.bss`: address space only, not part of the file); it is never read or written.
static HANDLE_SPACE: [AtomicU8; HANDLE_COUNT] = [const { AtomicU8::new(0) }; HANDLE_COUNT];

struct Entry {
    /// The component: an address inside [`HANDLE_SPACE`].
    handle: usize,
    /// `Box::into_raw` of the instance.
    instance: usize,
    /// The model type of the instance (a process may hold several in tests).
    model: TypeId,
}

struct Registry {
    live: Vec<Entry>,
    /// The offset in [`HANDLE_SPACE`] of the next handle.
    next: usize,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    live: Vec::new(),
    next: 0,
});

/// The registry; a poisoned lock is taken as it is (nothing panics while holding it, and the
/// list stays consistent between statements).
fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl Registry {
    /// The next handle in turn that is not live (all of them live would take 16 Mi instances).
    fn take_handle(&mut self) -> Fmi2Component {
        loop {
            let handle = HANDLE_SPACE[self.next].as_ptr().cast();
            self.next = (self.next + 1) % HANDLE_COUNT;
            if self
                .live
                .iter()
                .all(|entry| entry.handle != handle as usize)
            {
                return handle;
            }
        }
    }
}

/// Lists `instance` (from `Box::into_raw`) of model `model` and returns its component.
pub(crate) fn register(instance: usize, model: TypeId) -> Fmi2Component {
    let mut registry = registry();
    let handle = registry.take_handle();
    registry.live.push(Entry {
        handle: handle as usize,
        instance,
        model,
    });
    handle
}

/// The instance of `component` if it is a live instance of `model`.
pub(crate) fn lookup(component: Fmi2Component, model: TypeId) -> Option<usize> {
    let key = component as usize;
    registry()
        .live
        .iter()
        .find(|entry| entry.handle == key && entry.model == model)
        .map(|entry| entry.instance)
}

/// Unlists `component` and returns its instance, for the caller to drop; `None` when it is not
/// a live instance of `model` (freed already, or never ours).
pub(crate) fn unregister(component: Fmi2Component, model: TypeId) -> Option<usize> {
    let key = component as usize;
    let mut registry = registry();
    let position = registry
        .live
        .iter()
        .position(|entry| entry.handle == key && entry.model == model)?;
    Some(registry.live.swap_remove(position).instance)
}
