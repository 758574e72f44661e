//! `pn-lab` — placeholder, filled by the next commits.
