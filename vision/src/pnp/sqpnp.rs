//! SQPnP (Terzakis and Lourakis 2020): globally optimal PnP for 3 or more points.
