//! Live mode: `nes watch` re-renders a scene on every save ([`watch`]) and
//! can show it in a browser ([`serve`]). It drives the pipeline from the
//! outside and keeps the last good image; the pipeline knows nothing of
//! it.

pub mod serve;
pub mod watch;
