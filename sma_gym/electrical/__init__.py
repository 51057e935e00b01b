"""Electrical side: supply and PWM switch (``pwm``), multiplexer timing (``multiplexer``)
and sensors (``sensors``)."""
