//! Lambda Twist P3P (Persson and Nordberg 2018).
