//! Reference solutions: point source in an infinite medium (P_N, CDA, Grosjean).
