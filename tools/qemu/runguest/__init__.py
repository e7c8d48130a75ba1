"""tools/qemu/run-guest split by concern (tools/qemu/README.md "How it works"):

  common  exit codes, console markers, HarnessError, log
  cpio    initramfs layers (cpio "newc"), their content key and cache
  kernel  the Debian kernel to boot (PVH vmlinux extraction) and its CAN modules
  image   the three layers: base (busybox, can-utils, modules, /init), extra (--bin/--file), run
  qemu    running QEMU, reading the guest console, unpacking /out
  cli     the command line and main()
"""
