/* Calls into both libraries (no device needed) and prints their run-time versions. */
#include <gpiod.h>
#include <modbus.h>
#include <stdio.h>

int main(void) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 1502);
  if (ctx == NULL) return 1;
  if (modbus_set_slave(ctx, 1) != 0) return 2;
  modbus_free(ctx);
  printf("libmodbus %u.%u.%u libgpiod %s pointer %zu bits\n", libmodbus_version_major,
         libmodbus_version_minor, libmodbus_version_micro, gpiod_version_string(),
         8 * sizeof(void*));
  return 0;
}
