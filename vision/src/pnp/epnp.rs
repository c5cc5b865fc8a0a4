//! EPnP (Lepetit, Moreno-Noguer and Fua 2009).
