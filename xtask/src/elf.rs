//! ELF reading
