//! MDG virtual machine.
