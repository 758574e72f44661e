//! `pn-render` — placeholder, filled by the next commits.
