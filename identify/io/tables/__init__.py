"""Tables read from CSV: characteristic tables and operating points."""
