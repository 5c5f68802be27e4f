//! Test support: a vehicle-side mission server, a virtual-time simulated
//! link and a lossy UDP relay. Public so that integration tests and the
//! simulator can stand in for a real autopilot.

pub mod ardupilot;
pub mod relay;
pub mod sim;
pub mod vehicle;

pub use relay::{Impairment, ImpairmentCounts, UdpRelay};
pub use sim::SimLink;
pub use vehicle::{spawn_udp_vehicle, MissionServer, UdpVehicle, VehicleConfig};
