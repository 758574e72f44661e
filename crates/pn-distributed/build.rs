//! With the `petsc` feature: compiles the small C shim (`src/petsc/shim.c`) against PETSc and
//! MPI found by pkg-config, and links them. The shim checks at compile time that PETSc's
//! `PetscInt` is 32-bit, `PetscScalar` a real double and the enum values the Rust side
//! declares are PETSc's (`_Static_assert`), so a PETSc built otherwise fails the build
//! instead of corrupting memory. Without the feature: nothing.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    #[cfg(feature = "petsc")]
    petsc::build();
}

#[cfg(feature = "petsc")]
mod petsc {
    #[expect(
        clippy::panic,
        reason = "a build script reports a missing system library by failing the build"
    )]
    pub fn build() {
        println!("cargo:rerun-if-changed=src/petsc/shim.c");
        let found = |name: &str| {
            pkg_config::Config::new().probe(name).unwrap_or_else(|e| {
                panic!(
                    "the `petsc` feature needs {name} from pkg-config (Debian: apt-get install \
                     petsc-dev openmpi-bin libopenmpi-dev pkg-config): {e}"
                )
            })
        };
        let petsc = found("PETSc");
        let mpi = found("ompi");
        let mut cc = cc::Build::new();
        cc.file("src/petsc/shim.c")
            .warnings(true)
            .extra_warnings(true);
        for p in petsc.include_paths.iter().chain(&mpi.include_paths) {
            cc.include(p);
        }
        cc.compile("pn_petsc_shim");
    }
}
