"""The OPC UA server face: the gateway's loops, controllers and axes as an OPC UA address
space (asyncua), with methods that call the same service layer as the REST API and MQTT."""
