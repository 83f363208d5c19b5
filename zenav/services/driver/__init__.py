"""The driver service: a ROSArduinoBridge motor board (Arduino, motor driver, quadrature encoders) over a serial port."""
