//! Studies (in progress).
