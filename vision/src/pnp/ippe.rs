//! IPPE, infinitesimal plane-based pose estimation (Collins and Bartoli 2014).
