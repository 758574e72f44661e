//! `pn-runtime` — from a scene to a solved system.
