//! Placeholder of the RTIC application (filled by the firmware issue). It only proves that the
//! core links into a `thumbv7em-none-eabihf` image.
#![no_std]
#![no_main]
