mod chess;
mod detection;
mod multiscale;
mod radon;
mod refiner;
mod uncertainty;

#[cfg(test)]
mod tests;

pub use chess::{ChessConfig, ChessRing, OnRefinerReject};
pub use detection::{DetectionParams, DetectionStrategy, DetectorConfig};
pub use multiscale::MultiscaleConfig;
pub use radon::RadonConfig;
pub use refiner::ImageRefiner;
pub use uncertainty::{NoiseLevel, Uncertainty};
