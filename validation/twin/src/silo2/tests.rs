//! Tests of the SILO2 twin.
