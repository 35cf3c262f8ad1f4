//! raylab's integration tests, in one binary (one link instead of a dozen on a small machine;
//! ripgrep's layout). Each module tests one part of the program through its library or its
//! real binary.

mod agreement;
mod architecture;
mod assets;
mod bench;
#[cfg(feature = "embree")]
mod bench_embree;
mod cli;
mod common;
mod compare;
mod corpus;
mod files;
mod guiding;
mod lights;
mod media;
mod mitsuba;
mod new_integrator;
mod passes;
mod pbrt;
mod photons;
mod proptest_loader;
mod serve;
mod shards;
mod spectral;
mod textures;
mod watch;
