//! `pn-krylov` — placeholder, filled by the next commit.
