"""What a polarization camera records from a Stokes image: polarizer images,
sensor mosaics (Sony IMX250MZR/MYR) and sensor noise (:mod:`.polcam`)."""
