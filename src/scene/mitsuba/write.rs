//! The Mitsuba 3 XML writer.
